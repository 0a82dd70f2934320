use super::*;

fn sample() -> (Header, BaseSection) {
    let header = Header {
        bits: 12,
        level: 3,
        update: 2,
        weight_bits: 1,
        normal_bits: 2,
        frames: 1,
        origin: [0.5, -1.0, 2.0],
        step: 0.001,
        base_vertices: 4,
        base_faces: 1,
        planes: 14,
        passes: 14,
        flags: 10,
        holds: vec![[3, 9], [9, 12], [300, 70_000]],
        colour: None,
    };
    // 14 planes at level 3 leave room for the low 10 bits in the
    // stream; the flags say it holds them all.
    let low_bits = header.stream_params().base_bits;
    assert_eq!(low_bits, 10);
    let values = [[0, 0, 0], [4095, 0, 7], [4095, 4095, -3], [0, 4095, 9]];
    let base = BaseSection {
        faces: vec![[0, 1, 2, 3]],
        values: values.map(|v| v.map(|x| x >> low_bits)).to_vec(),
        low_bits,
    };
    (header, base)
}

/// Holds survive the round trip, map cuts inside them to their start,
/// and overlapping or empty ones are refused.
#[test]
fn holds_round_trip_and_map_cuts() {
    let (header, base) = sample();
    let bytes = write(&header, &base, b"").unwrap();
    let c = read(&bytes, &Limits::DEFAULT).unwrap();
    assert_eq!(c.header.holds, header.holds);
    let cuts = [
        0, 3, 4, 8, 9, 10, 11, 12, 13, 300, 301, 69_999, 70_000, 70_001,
    ];
    let mapped = [0, 3, 3, 3, 9, 9, 9, 12, 13, 300, 300, 300, 70_000, 70_001];
    assert_eq!(cuts.map(|n| header.hold_cut(n)), mapped);
    for holds in [vec![[3, 3]], vec![[3, 9], [8, 12]], vec![[9, 3]]] {
        let mut bad = header.clone();
        bad.holds = holds;
        assert!(write(&bad, &base, b"").is_err(), "{:?}", bad.holds);
    }
    // More holds than a 64 KiB header holds: refused, not wrapped.
    let mut many = header.clone();
    many.holds = (0..40_000).map(|k| [3 * k, 3 * k + 1]).collect();
    assert!(matches!(write(&many, &base, b""), Err(Error::Limit { .. })));
}

/// A header whose holds, added up, pass 4 GiB is refused.
#[test]
fn holds_beyond_4_gib_are_refused() {
    let (header, base) = sample();
    let good = write(&header, &base, b"").unwrap();
    let mut raw = bincode::serde::encode_to_vec(&header, config()).unwrap();
    let relative: Vec<[u32; 2]> = vec![[u32::MAX - 1, 1], [1, 1]];
    bincode::serde::encode_into_std_write(&relative, &mut raw, config()).unwrap();
    let mut bytes = MAGIC.to_vec();
    bytes.push(VERSION);
    bytes.extend_from_slice(&(raw.len() as u16).to_le_bytes());
    bytes.extend_from_slice(&raw);
    bytes.extend_from_slice(&crc32(&bytes).to_le_bytes());
    let old_header = 7 + u16::from_le_bytes([good[5], good[6]]) as usize + 4;
    bytes.extend_from_slice(&good[old_header..]);
    match read(&bytes, &Limits::DEFAULT) {
        Err(Error::Malformed { what }) => assert!(what.contains("4 GiB"), "{what}"),
        other => panic!("{other:?}"),
    }
}

/// A high part whose value with its low bits would leave 32 bits is
/// refused.
#[test]
fn base_high_parts_out_of_range_are_refused() {
    let (header, mut base) = sample();
    base.values[2][1] = i32::MAX >> 10;
    assert!(read(&write(&header, &base, b"").unwrap(), &Limits::DEFAULT).is_ok());
    base.values[2][1] = (i32::MAX >> 10) + 1;
    let bytes = write(&header, &base, b"").unwrap();
    match read(&bytes, &Limits::DEFAULT) {
        Err(Error::Malformed { what }) => assert!(what.contains("out of range"), "{what}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn round_trip_and_stream_follows() {
    let (header, base) = sample();
    let bytes = write(&header, &base, b"stream!").unwrap();
    let c = read(&bytes, &Limits::DEFAULT).unwrap();
    assert_eq!(c.header, header);
    assert_eq!(c.base, base);
    assert_eq!(c.stream, b"stream!");
    assert_eq!(c.header_bytes + c.base_bytes + 7, bytes.len());
}

#[test]
fn cuts_before_the_stream_name_the_bytes_needed() {
    let (header, base) = sample();
    let bytes = write(&header, &base, b"").unwrap();
    for cut in 0..bytes.len() {
        match read(&bytes[..cut], &Limits::DEFAULT) {
            Err(Error::Truncated { needed, available }) => {
                assert_eq!(available, cut);
                assert!(needed > cut && needed <= bytes.len());
            }
            other => panic!("cut {cut}: {other:?}"),
        }
    }
    assert!(read(&bytes, &Limits::DEFAULT).is_ok());
}

#[test]
fn corruption_is_caught_by_checksums() {
    let (header, base) = sample();
    let bytes = write(&header, &base, b"").unwrap();
    for i in 7..bytes.len() {
        let mut bad = bytes.clone();
        bad[i] ^= 0x10;
        assert!(
            read(&bad, &Limits::DEFAULT).is_err(),
            "flip at {i} went unnoticed"
        );
    }
    let mut bad = bytes.clone();
    bad[0] = b'X';
    assert!(matches!(read(&bad, &Limits::DEFAULT), Err(Error::NotQm)));
    let mut bad = bytes;
    bad[4] = 9;
    assert!(matches!(
        read(&bad, &Limits::DEFAULT),
        Err(Error::UnsupportedVersion { found: 9, .. })
    ));
}

/// More base bits in the stream than it has planes for are refused
/// with what is wrong; so are reserved flags, by the writer (the
/// reader's refusal is in the hostile corpus).
#[test]
fn impossible_base_bits_and_unknown_flags_are_refused() {
    let (mut header, base) = sample();
    header.flags = 11;
    let mut base = base.clone();
    base.low_bits = header.stream_params().base_bits;
    let bytes = write(&header, &base, b"").unwrap();
    match read(&bytes, &Limits::DEFAULT) {
        Err(Error::Malformed { what }) => assert!(what.contains("planes for 10"), "{what}"),
        other => panic!("{other:?}"),
    }
    base.low_bits = 10;
    // The implied split is for level 0 alone (the sample is level 3).
    let implied = Header {
        flags: IMPLIED_SPLIT | 10,
        ..header.clone()
    };
    match write(&implied, &base, b"") {
        Err(Error::Malformed { what }) => assert!(what.contains("at level 3"), "{what}"),
        other => panic!("{other:?}"),
    }
    let colourless = Header {
        flags: COLOUR | 10,
        ..header.clone()
    };
    match write(&colourless, &base, b"") {
        Err(Error::Malformed { what }) => assert!(what.contains("colour header"), "{what}"),
        other => panic!("{other:?}"),
    }
    for flags in [0x200 | 10, 0x100 | 10, 1 << 31] {
        let header = Header {
            flags,
            ..header.clone()
        };
        let base = BaseSection {
            low_bits: header.stream_params().base_bits,
            ..base.clone()
        };
        match write(&header, &base, b"") {
            Err(Error::Malformed { what }) => assert!(what.contains("reserved"), "{what}"),
            other => panic!("flags {flags:#x}: {other:?}"),
        }
    }
}

/// A header that asks for more memory than the limit is refused from
/// the header alone, saying what it asks for; a higher limit lets it
/// through to the next check.
#[test]
fn memory_is_limited_by_the_header() {
    let (mut header, mut base) = sample();
    header.level = 11;
    header.flags = 0;
    base.low_bits = 0;
    let bytes = write(&header, &base, b"").unwrap();
    let needed = decode_memory(&header);
    assert_eq!(sample_count(&header), 4 + 4 * 2047 + 2047 * 2047);
    let unchecked = Header {
        level: 200,
        ..header.clone()
    };
    assert_eq!(sample_count(&unchecked), u64::MAX);
    match read(&bytes, &Limits::DEFAULT.with_max_memory(needed - 1)) {
        Err(e @ Error::Memory { .. }) => {
            let text = e.to_string();
            assert!(text.contains("4198401 samples"), "{text}");
        }
        other => panic!("{other:?}"),
    }
    assert!(read(&bytes, &Limits::DEFAULT.with_max_memory(needed)).is_ok());
    assert!(
        read(&bytes, &Limits::DEFAULT).is_ok(),
        "640 MiB is under 1 GiB"
    );
    header.level = 12;
    let bytes = write(&header, &base, b"").unwrap();
    assert!(matches!(
        read(&bytes, &Limits::DEFAULT.with_max_samples(u64::MAX)),
        Err(Error::Memory { .. })
    ));
}

#[test]
fn absurd_sizes_are_refused() {
    let (mut header, mut base) = sample();
    header.level = 12;
    header.base_faces = 1 << 20;
    header.flags = 0;
    base.low_bits = header.stream_params().base_bits;
    let bytes = write(&header, &base, b"").unwrap();
    assert!(matches!(
        read(&bytes, &Limits::DEFAULT),
        Err(Error::Limit { .. })
    ));
}

/// A colour header comes back as written after the holds; one that asks
/// for impossible planes, weights or runs is refused, and so is a cut
/// inside it.
#[test]
fn colour_headers_round_trip_and_bad_ones_are_refused() {
    let (header, base) = sample();
    let colour = ColourHeader {
        planes: 18,
        passes: 18,
        weight_bits: 1,
        luma_bits: 1,
        base_bits: 12,
        base_min: [-3, 1900, 2047],
        base_max: [400, 2000, 2047],
        runs: vec![[100, 40], [0, 7], [900, 0]],
        finer: 0,
    };
    let coloured = Header {
        flags: header.flags | COLOUR,
        colour: Some(colour.clone()),
        ..header.clone()
    };
    let bytes = write(&coloured, &base, b"stream").unwrap();
    let c = read(&bytes, &Limits::DEFAULT).unwrap();
    assert_eq!(c.header, coloured);
    assert_eq!(c.stream, b"stream");
    let bad = [
        ColourHeader {
            planes: 60,
            ..colour.clone()
        },
        ColourHeader {
            passes: 19,
            ..colour.clone()
        },
        ColourHeader {
            luma_bits: 9,
            ..colour.clone()
        },
        ColourHeader {
            base_bits: 20,
            ..colour.clone()
        },
        ColourHeader {
            runs: vec![[u32::MAX, 1], [1, 1]],
            ..colour.clone()
        },
        ColourHeader {
            base_max: [4093, 2000, 2047],
            ..colour.clone()
        },
        ColourHeader {
            base_min: [-3, 2001, 2047],
            ..colour.clone()
        },
    ];
    for (i, colour) in bad.into_iter().enumerate() {
        let file = sealed_header(&Header {
            colour: Some(colour),
            ..coloured.clone()
        });
        match read(&file, &Limits::DEFAULT) {
            Err(Error::Malformed { what }) => assert!(what.contains("colour"), "case {i}: {what}"),
            other => panic!("case {i}: {other:?}"),
        }
    }
    // Finer colour: its byte after the runs comes back; it needs its
    // flag, the flag needs colour, and the levels are bounded.
    let finer = Header {
        flags: coloured.flags | FINER_COLOUR,
        colour: Some(ColourHeader {
            finer: 2,
            ..colour.clone()
        }),
        ..coloured.clone()
    };
    let bytes = write(&finer, &base, b"stream").unwrap();
    assert_eq!(read(&bytes, &Limits::DEFAULT).unwrap().header, finer);
    let unflagged = Header {
        flags: coloured.flags,
        ..finer.clone()
    };
    assert!(write(&unflagged, &base, b"").is_err());
    let bad = [
        (coloured.flags | FINER_COLOUR, 0),
        (coloured.flags | FINER_COLOUR, MAX_FINER_COLOUR + 1),
        (header.flags | FINER_COLOUR, 1),
    ];
    for (i, (flags, finer)) in bad.into_iter().enumerate() {
        let file = sealed_header(&Header {
            flags,
            colour: (flags & COLOUR != 0).then(|| ColourHeader {
                finer,
                ..colour.clone()
            }),
            ..coloured.clone()
        });
        match read(&file, &Limits::DEFAULT) {
            Err(Error::Malformed { what }) => assert!(what.contains("colour"), "finer {i}: {what}"),
            other => panic!("finer {i}: {other:?}"),
        }
    }
    // Finer colour counts its samples against the limits.
    let limits = Limits {
        max_samples: sample_count(&coloured),
        ..Limits::DEFAULT
    };
    assert!(read(&write(&coloured, &base, b"").unwrap(), &limits).is_ok());
    let fine = write(&finer, &base, b"").unwrap();
    assert!(matches!(read(&fine, &limits), Err(Error::Limit { .. })));
    // The flag without the header after the holds: the header ends early.
    let file = sealed_header(&Header {
        colour: None,
        ..coloured.clone()
    });
    match read(&file, &Limits::DEFAULT) {
        Err(Error::Malformed { what }) => assert!(what.contains("colour header"), "{what}"),
        other => panic!("{other:?}"),
    }
}

/// Magic, version, length, `header`'s bytes unchecked and their valid
/// checksum: what `read` parses before the base section.
fn sealed_header(header: &Header) -> Vec<u8> {
    let bytes = encode_header(header).unwrap();
    let mut file = MAGIC.to_vec();
    file.push(VERSION);
    file.extend_from_slice(&(bytes.len() as u16).to_le_bytes());
    file.extend_from_slice(&bytes);
    file.extend_from_slice(&crc32(&file).to_le_bytes());
    file
}
