//! The `.qm` container: magic, header, base mesh, embedded stream.
//!
//! | bytes | content |
//! |---|---|
//! | 4 | magic `89 51 4D 0A` (`\x89QM\n`) |
//! | 1 | format version ([`VERSION`]) |
//! | 2 | header length `H`, little endian |
//! | `H` | [`Header`], bincode (standard configuration: varints); version 4 and later: then its [`Header::holds`], bincode, each as the gap from the last hold's end and its length |
//! | 4 | CRC-32 of everything above |
//! | 4 | base section length `B`, little endian |
//! | `B` | base mesh: face corners, then the level-0 scaling values, predicted and arithmetic-coded (see `basecode`; version 1: bincode, delta-coded; version 3: without their low bits, which are in the stream) |
//! | 4 | CRC-32 of the base section |
//! | rest | the embedded EZW stream, to the end of the data |
//!
//! The stream has no length field and no checksum: any prefix of it is a
//! valid, coarser stream. Everything before it is checked, and a cut there is
//! reported with the number of bytes needed.

use serde::{Deserialize, Serialize};

use crate::{Error, Result, basecode};

/// Magic bytes at the start of every `.qm` file.
pub const MAGIC: [u8; 4] = [0x89, b'Q', b'M', b'\n'];

/// The newest container version this build writes. Version 3 moved the
/// low bits of the base values into the embedded stream
/// (how many: [`Header::flags`]); version 4 added the stream's holds
/// ([`Header::holds`]); version 5 the bit-plane coder's neighbour contexts
/// ([`NEIGHBOUR_CONTEXTS`] in [`Header::flags`]). The encoder writes
/// version 5 with its default, neighbour contexts, holds or not; with the
/// tree contexts alone ([`qm_ezw::Contexts::Tree`]) it writes what it did
/// before: version 4 when a stream has holds, version 3 otherwise, and
/// version 2 (all base bits in the base section) on request.
pub const VERSION: u8 = 5;

/// Largest [`Header::frames`]: parent-quad normals from level
/// `MAX_LEVEL + 1` on, that is never.
pub const MAX_FRAMES: u8 = qm_lift::MAX_LEVEL as u8 - 1;

/// The first level whose frames use parent-quad normals for a
/// [`Header::frames`] value, `None` for world axes.
pub fn parent_frames_from(frames: u8) -> Option<u32> {
    (frames > 0).then_some(frames as u32 + 2)
}

/// The oldest container version this build still reads. Version 1 had no
/// `normal_bits` and `frames` fields: its details are in world axes.
pub const OLDEST_VERSION: u8 = 1;

/// Everything a decoder needs besides the base mesh and the stream.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// Container version: the byte before the header, not part of it
    /// (2 and 3 share the header's fields).
    #[serde(skip)]
    pub version: u8,
    /// Quantization bits per coordinate.
    pub bits: u8,
    /// Subdivision levels above the base mesh.
    pub level: u8,
    /// Lifting update rule ([`qm_lift::UpdateRule::code`]).
    pub update: u8,
    /// Weighting bits per level of the bit-plane coder.
    pub weight_bits: u8,
    /// Extra weighting bits of the first (normal) coordinate (version 2).
    pub normal_bits: u8,
    /// Details in world axes (0), or in local frames, normal first, whose
    /// normals come from the parent quads from level `frames + 2` on
    /// (`1..=`[`MAX_FRAMES`]; version 2).
    pub frames: u8,
    /// Quantization grid origin.
    pub origin: [f64; 3],
    /// Quantization step.
    pub step: f64,
    /// Number of base vertices.
    pub base_vertices: u32,
    /// Number of base faces.
    pub base_faces: u32,
    /// Bit planes of the complete stream.
    pub planes: u8,
    /// Passes the stream holds (at most `planes`).
    pub passes: u8,
    /// Version 3: the low bits of each base value the stream carries
    /// ([`qm_ezw::StreamParams::base_bits`]) in bits 0 to 4. Version 5:
    /// [`NEIGHBOUR_CONTEXTS`]. The other bits (all of them before version 3)
    /// are reserved, zero.
    pub flags: u32,
    /// Version 4: cuts of the stream that decode as a shorter cut. A
    /// stream prefix of `n` bytes with `from < n < to` for a hold
    /// `[from, to]` decodes as its first `from` bytes, because the encoder
    /// measured those closer to the surface than any cut in between (see
    /// [`Self::hold_cut`]). Offsets count stream bytes; the holds are
    /// ordered and do not overlap. Not part of the bincode header struct:
    /// written after it.
    #[serde(skip)]
    pub holds: Vec<[u32; 2]>,
}

/// [`Header::hold_cut`] for ordered, non-overlapping `holds`.
pub fn hold_cut(holds: &[[u32; 2]], n: usize) -> usize {
    let i = holds.partition_point(|h| h[1] as usize <= n);
    match holds.get(i) {
        Some(&[from, _]) if (from as usize) < n => from as usize,
        _ => n,
    }
}

/// The flags' bits that hold the base bits in the stream (version 3).
pub const BASE_BITS_MASK: u32 = 0x1f;

/// The flag of a stream coded with [`qm_ezw::Contexts::Neighbours`]
/// (version 5; without it, [`qm_ezw::Contexts::Tree`]).
pub const NEIGHBOUR_CONTEXTS: u32 = 0x20;

/// The first version whose header carries holds.
pub const HOLDS_VERSION: u8 = 4;

/// What a header of a given version can carry: the one place that knows
/// which version brought what.
#[derive(Clone, Copy, Debug)]
struct Features {
    /// Base values' low bits in the stream, counted in the flags (3).
    base_bits: bool,
    /// A list of holds after the header fields ([`HOLDS_VERSION`]).
    holds: bool,
    /// The flags it may set.
    flags: u32,
}

impl Features {
    const fn of(version: u8) -> Features {
        Features {
            base_bits: version >= 3,
            holds: version >= HOLDS_VERSION,
            flags: match version {
                0..=2 => 0,
                3 | 4 => BASE_BITS_MASK,
                _ => BASE_BITS_MASK | NEIGHBOUR_CONTEXTS,
            },
        }
    }
}

impl Header {
    /// The first level whose frames use parent-quad normals, `None` for
    /// world axes (see [`Self::frames`]).
    pub fn parent_frames_from(&self) -> Option<u32> {
        parent_frames_from(self.frames)
    }

    /// How many of the first `n` stream bytes a decoder uses: `from` when
    /// `n` falls strictly inside a hold `[from, to]`, `n` otherwise.
    pub fn hold_cut(&self, n: usize) -> usize {
        hold_cut(&self.holds, n)
    }

    /// What the bit-plane decoder must be told about the stream.
    pub fn stream_params(&self) -> qm_ezw::StreamParams {
        let weighting = qm_ezw::Weighting {
            bits_per_level: self.weight_bits as u32,
            normal_bits: self.normal_bits as u32,
        };
        let features = Features::of(self.version);
        let base_bits = if features.base_bits {
            self.flags & BASE_BITS_MASK
        } else {
            0
        };
        let contexts = if self.flags & features.flags & NEIGHBOUR_CONTEXTS != 0 {
            qm_ezw::Contexts::Neighbours
        } else {
            qm_ezw::Contexts::Tree
        };
        qm_ezw::StreamParams {
            planes: self.planes as u32,
            passes: self.passes as u32,
            weighting,
            base_bits,
            contexts,
        }
    }
}

/// The version 1 header: the same fields but `normal_bits` and `frames`.
#[derive(Deserialize)]
struct HeaderV1 {
    bits: u8,
    level: u8,
    update: u8,
    weight_bits: u8,
    origin: [f64; 3],
    step: f64,
    base_vertices: u32,
    base_faces: u32,
    planes: u8,
    passes: u8,
    flags: u32,
}

impl From<HeaderV1> for Header {
    fn from(h: HeaderV1) -> Header {
        Header {
            version: 1,
            bits: h.bits,
            level: h.level,
            update: h.update,
            weight_bits: h.weight_bits,
            normal_bits: 0,
            frames: 0,
            origin: h.origin,
            step: h.step,
            base_vertices: h.base_vertices,
            base_faces: h.base_faces,
            planes: h.planes,
            passes: h.passes,
            flags: h.flags,
            holds: Vec::new(),
        }
    }
}

/// The base mesh as stored: corners of each face, then the level-0 scaling
/// value of each base vertex without its low bits.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BaseSection {
    /// Counter-clockwise corners of each base face.
    pub faces: Vec<[u32; 4]>,
    /// Quantized level-0 values, one per base vertex, shifted right
    /// (arithmetically) by `low_bits`.
    pub values: Vec<[i32; 3]>,
    /// Low bits of each value that are in the stream instead
    /// ([`qm_ezw::StreamParams::base_bits`]; 0 before version 3).
    pub low_bits: u32,
}

/// The version 1 base section.
#[derive(Deserialize)]
struct StoredBase {
    faces: Vec<[u32; 4]>,
    deltas: Vec<[i32; 3]>,
}

/// A parsed container: header, base mesh and the stream bytes that follow.
#[derive(Clone, Debug)]
pub struct Container<'a> {
    /// The header.
    pub header: Header,
    /// The base mesh.
    pub base: BaseSection,
    /// The embedded stream (as much of it as is present).
    pub stream: &'a [u8],
    /// Bytes of magic, version, header and its checksum.
    pub header_bytes: usize,
    /// Bytes of the base section with its length and checksum.
    pub base_bytes: usize,
}

fn config() -> bincode::config::Configuration {
    bincode::config::standard()
}

/// Writes a complete container of version `header.version` (2 to 5; holds
/// need version 4 or later, neighbour contexts version 5).
pub fn write(header: &Header, base: &BaseSection, stream: &[u8]) -> Result<Vec<u8>> {
    let low_bits = header.stream_params().base_bits;
    let features = Features::of(header.version);
    if !features.holds && !header.holds.is_empty() {
        return Err(Error::Malformed {
            what: format!("holds in a version {} header", header.version),
        });
    }
    check_holds(&header.holds)?;
    let unknown = header.flags & !features.flags;
    if unknown != 0 {
        return Err(Error::Malformed {
            what: format!("flags {unknown:#x} in a version {} header", header.version),
        });
    }
    if !(2..=VERSION).contains(&header.version) || base.low_bits != low_bits {
        return Err(Error::Malformed {
            what: format!(
                "version {} with {} low base bits in the stream ({low_bits} expected)",
                header.version, base.low_bits
            ),
        });
    }
    let mut header_bytes =
        bincode::serde::encode_to_vec(header, config()).map_err(|e| Error::Malformed {
            what: e.to_string(),
        })?;
    if features.holds {
        let mut end = 0;
        let relative: Vec<[u32; 2]> = (header.holds.iter())
            .map(|&[from, to]| {
                let gap = from - end;
                end = to;
                [gap, to - from]
            })
            .collect();
        bincode::serde::encode_into_std_write(&relative, &mut header_bytes, config()).map_err(
            |e| Error::Malformed {
                what: e.to_string(),
            },
        )?;
    }
    let header_len = u16::try_from(header_bytes.len()).map_err(|_| Error::Limit {
        what: "header length (holds)",
        value: header_bytes.len() as u64,
        max: u16::MAX as u64,
    })?;
    let mut out = Vec::with_capacity(64 + stream.len());
    out.extend_from_slice(&MAGIC);
    out.push(header.version);
    out.extend_from_slice(&header_len.to_le_bytes());
    out.extend_from_slice(&header_bytes);
    out.extend_from_slice(&crc32fast::hash(&out).to_le_bytes());

    let base_bytes = basecode::encode(&base.faces, &base.values);
    out.extend_from_slice(&(base_bytes.len() as u32).to_le_bytes());
    out.extend_from_slice(&base_bytes);
    out.extend_from_slice(&crc32fast::hash(&base_bytes).to_le_bytes());
    out.extend_from_slice(stream);
    Ok(out)
}

/// Most extra weighting bits of the normal coordinate.
pub const MAX_NORMAL_BITS: u8 = 8;

/// Decoder limits on what header fields may ask for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub struct Limits {
    /// Most base vertices.
    pub max_base_vertices: u32,
    /// Most base faces.
    pub max_base_faces: u32,
    /// Most samples of the decoded mesh.
    pub max_samples: u64,
}

impl Limits {
    /// Defaults: 4M base vertices and faces, 64M samples (a few GiB of memory).
    pub const DEFAULT: Limits = Limits {
        max_base_vertices: 1 << 22,
        max_base_faces: 1 << 22,
        max_samples: 1 << 26,
    };

    /// Sets the sample limit.
    pub const fn with_max_samples(mut self, max: u64) -> Self {
        self.max_samples = max;
        self
    }
}

impl Limits {
    /// No limits beyond what the format itself can describe: for bytes the
    /// caller wrote itself.
    pub const NONE: Limits = Limits {
        max_base_vertices: u32::MAX,
        max_base_faces: u32::MAX,
        max_samples: u64::MAX,
    };
}

impl Default for Limits {
    fn default() -> Self {
        Limits::DEFAULT
    }
}

fn take(data: &[u8], at: usize, len: usize) -> Result<&[u8]> {
    data.get(at..at + len).ok_or(Error::Truncated {
        needed: at + len,
        available: data.len(),
    })
}

fn limit(what: &'static str, value: u64, max: u64) -> Result<()> {
    if value > max {
        Err(Error::Limit { what, value, max })
    } else {
        Ok(())
    }
}

/// Parses the header and base mesh of `data`, checking checksums and limits.
pub fn read<'a>(data: &'a [u8], limits: &Limits) -> Result<Container<'a>> {
    let magic = take(data, 0, 4)?;
    if magic != MAGIC {
        return Err(Error::NotQm);
    }
    let version = take(data, 4, 1)?[0];
    if !(OLDEST_VERSION..=VERSION).contains(&version) {
        return Err(Error::UnsupportedVersion {
            found: version,
            oldest: OLDEST_VERSION,
            newest: VERSION,
        });
    }
    let header_len = u16::from_le_bytes(take(data, 5, 2)?.try_into().expect("2 bytes")) as usize;
    let header_raw = take(data, 7, header_len)?;
    let crc = u32::from_le_bytes(take(data, 7 + header_len, 4)?.try_into().expect("4 bytes"));
    if crc != crc32fast::hash(&data[..7 + header_len]) {
        return Err(Error::Checksum { section: "header" });
    }
    let header: Header = match version {
        1 => decode_exact::<HeaderV1>(header_raw, "header")?.into(),
        _ if !Features::of(version).holds => Header {
            version,
            ..decode_exact(header_raw, "header")?
        },
        _ => {
            let (header, relative): (Header, Vec<[u32; 2]>) = decode_exact(header_raw, "header")?;
            let mut end = 0u32;
            let mut holds = Vec::with_capacity(relative.len());
            for [gap, len] in relative {
                let from = end.checked_add(gap);
                let to = from.and_then(|f| f.checked_add(len));
                let (Some(from), Some(to)) = (from, to) else {
                    return Err(Error::Malformed {
                        what: "a hold beyond 4 GiB".into(),
                    });
                };
                holds.push([from, to]);
                end = to;
            }
            Header {
                version,
                holds,
                ..header
            }
        }
    };
    let header_bytes = 7 + header_len + 4;
    check_header(&header, limits)?;

    let base_len =
        u32::from_le_bytes(take(data, header_bytes, 4)?.try_into().expect("4 bytes")) as usize;
    // A base mesh needs at least one byte per face corner; more is a lie.
    let most = 16 * (header.base_faces as usize + header.base_vertices as usize) + 16;
    if base_len > most {
        return Err(Error::Malformed {
            what: format!(
                "base section length {base_len} for {} faces",
                header.base_faces
            ),
        });
    }
    let base_raw = take(data, header_bytes + 4, base_len)?;
    let crc = u32::from_le_bytes(
        take(data, header_bytes + 4 + base_len, 4)?
            .try_into()
            .expect("4 bytes"),
    );
    if crc != crc32fast::hash(base_raw) {
        return Err(Error::Checksum {
            section: "base mesh",
        });
    }
    let base = if version == 1 {
        read_base_v1(base_raw, &header)?
    } else {
        let low_bits = header.stream_params().base_bits;
        basecode::decode(
            base_raw,
            header.base_faces as usize,
            header.base_vertices as usize,
            low_bits,
        )
        .map_err(|problem| Error::Malformed {
            what: format!("base mesh: {problem}"),
        })?
    };
    let base_bytes = 4 + base_len + 4;
    Ok(Container {
        header,
        base,
        stream: &data[header_bytes + base_bytes..],
        header_bytes,
        base_bytes,
    })
}

/// The version 1 base section: bincode faces and delta-coded values.
fn read_base_v1(raw: &[u8], header: &Header) -> Result<BaseSection> {
    let stored: StoredBase = decode_exact(raw, "base mesh")?;
    if stored.faces.len() != header.base_faces as usize
        || stored.deltas.len() != header.base_vertices as usize
    {
        return Err(Error::Malformed {
            what: format!(
                "base mesh holds {} faces and {} vertices, header says {} and {}",
                stored.faces.len(),
                stored.deltas.len(),
                header.base_faces,
                header.base_vertices
            ),
        });
    }
    let mut previous = [0i32; 3];
    let values = stored
        .deltas
        .iter()
        .map(|d| {
            previous = std::array::from_fn(|k| previous[k].wrapping_add(d[k]));
            previous
        })
        .collect();
    Ok(BaseSection {
        faces: stored.faces,
        values,
        low_bits: 0,
    })
}

fn decode_exact<T: serde::de::DeserializeOwned>(raw: &[u8], what: &str) -> Result<T> {
    // The limit stops a corrupt length prefix from allocating more than the
    // section could possibly hold.
    let cfg = config().with_limit::<{ 1 << 30 }>();
    let (value, used) = bincode::serde::decode_from_slice(raw, cfg).map_err(|e| {
        use bincode::error::DecodeError;
        let problem = match e {
            DecodeError::UnexpectedEnd { .. } => "it ends before its last field".to_string(),
            DecodeError::LimitExceeded => "a length field is larger than the section".to_string(),
            other => other.to_string(),
        };
        Error::Malformed {
            what: format!("{what}: {problem}"),
        }
    })?;
    if used != raw.len() {
        return Err(Error::Malformed {
            what: format!("{what}: {} trailing bytes", raw.len() - used),
        });
    }
    Ok(value)
}

/// Holds must be non-empty, ordered and apart: `from < to <= next from`.
fn check_holds(holds: &[[u32; 2]]) -> Result<()> {
    let mut end = 0;
    for &[from, to] in holds {
        if from < end || to <= from {
            return Err(Error::Malformed {
                what: format!("hold [{from}, {to}] after one ending at {end}"),
            });
        }
        end = to;
    }
    Ok(())
}

fn check_header(h: &Header, limits: &Limits) -> Result<()> {
    check_holds(&h.holds)?;
    limit(
        "base vertex count",
        h.base_vertices as u64,
        limits.max_base_vertices as u64,
    )?;
    limit(
        "base face count",
        h.base_faces as u64,
        limits.max_base_faces as u64,
    )?;
    limit(
        "subdivision level",
        h.level as u64,
        qm_lift::MAX_LEVEL as u64,
    )?;
    if !(qm_lift::MIN_BITS..=qm_lift::MAX_BITS).contains(&(h.bits as u32)) {
        return Err(Error::Malformed {
            what: format!("{} quantization bits", h.bits),
        });
    }
    if qm_lift::UpdateRule::from_code(h.update).is_none() {
        return Err(Error::Malformed {
            what: format!("unknown update rule {}", h.update),
        });
    }
    if h.frames > MAX_FRAMES {
        return Err(Error::Malformed {
            what: format!("unknown frame kind {}", h.frames),
        });
    }
    // Weighted planes cannot exceed the coefficient bits plus the weights.
    let most_planes =
        h.bits as u32 + 8 + h.weight_bits as u32 * h.level as u32 + h.normal_bits as u32;
    for (what, bits, most) in [
        ("level", h.weight_bits, 2),
        ("normal", h.normal_bits, MAX_NORMAL_BITS),
    ] {
        if bits > most {
            return Err(Error::Malformed {
                what: format!("{what} weight of {bits} bits (at most {most})"),
            });
        }
    }
    if h.planes as u32 > most_planes || h.passes > h.planes {
        return Err(Error::Malformed {
            what: format!("{} passes of {} planes", h.passes, h.planes),
        });
    }
    let features = Features::of(h.version);
    if h.flags & !features.flags != 0 {
        return Err(Error::Malformed {
            what: format!("unknown header flags {:#x}", h.flags & !features.flags),
        });
    }
    if features.base_bits {
        let params = h.stream_params();
        let most = params
            .weighting
            .max_base_bits(h.planes as u32, h.level as u32);
        if params.base_bits > most {
            return Err(Error::Malformed {
                what: format!(
                    "{} low base bits in the stream, which has planes for {most}",
                    params.base_bits
                ),
            });
        }
    }
    if !(h.step.is_finite() && h.step > 0.0 && h.origin.iter().all(|x| x.is_finite())) {
        return Err(Error::Malformed {
            what: "quantization origin or step is not finite".into(),
        });
    }
    // Upper bound of the sample count before anything is allocated.
    let n = 1u64 << h.level;
    let faces = h.base_faces as u64;
    let samples = h.base_vertices as u64 + 4 * faces * (n - 1) + faces * (n - 1) * (n - 1);
    limit("sample count", samples, limits.max_samples)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> (Header, BaseSection) {
        let header = Header {
            version: VERSION,
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

    /// Version 2 is still written on request, all base bits in the base
    /// section; the version must match the base section's low bits.
    #[test]
    fn version_2_round_trip() {
        let (mut header, mut base) = sample();
        header.version = 2;
        header.flags = 0;
        // Holds need version 4, and nothing else is wrong here.
        base.low_bits = 0;
        base.values = vec![[0, 0, 0], [4095, 0, 7], [4095, 4095, -3], [0, 4095, 9]];
        match write(&header, &base, b"") {
            Err(Error::Malformed { what }) => {
                assert!(what.contains("holds in a version 2"), "{what}")
            }
            other => panic!("{other:?}"),
        }
        header.holds.clear();
        // Low base bits in the stream need version 3.
        header.flags = 10;
        assert!(write(&header, &base, b"").is_err());
        header.flags = 0;
        let bytes = write(&header, &base, b"s").unwrap();
        assert_eq!(bytes[4], 2);
        let c = read(&bytes, &Limits::DEFAULT).unwrap();
        assert_eq!(
            (c.header, c.base, c.stream),
            (header.clone(), base.clone(), &b"s"[..])
        );
        header.version = 1;
        assert!(write(&header, &base, b"").is_err());
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

    /// A version 4 header whose holds, added up, pass 4 GiB is refused.
    #[test]
    fn holds_beyond_4_gib_are_refused() {
        let (header, base) = sample();
        let good = write(&header, &base, b"").unwrap();
        let mut raw = bincode::serde::encode_to_vec(&header, config()).unwrap();
        let relative: Vec<[u32; 2]> = vec![[u32::MAX - 1, 1], [1, 1]];
        bincode::serde::encode_into_std_write(&relative, &mut raw, config()).unwrap();
        let mut bytes = MAGIC.to_vec();
        bytes.push(4);
        bytes.extend_from_slice(&(raw.len() as u16).to_le_bytes());
        bytes.extend_from_slice(&raw);
        bytes.extend_from_slice(&crc32fast::hash(&bytes).to_le_bytes());
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
    /// with what is wrong; so are flags a version does not have, by the
    /// writer (the reader's refusal is in the hostile corpus,
    /// `qm-v4-neighbour-flag.qm` and `qm-header-flags-set.qm`).
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
        for (version, flags, expect) in [
            (5, 0x40 | 10, "flags 0x40 in a version 5"),
            (4, NEIGHBOUR_CONTEXTS | 10, "flags 0x20 in a version 4"),
        ] {
            let header = Header {
                version,
                flags,
                ..header.clone()
            };
            match write(&header, &base, b"") {
                Err(Error::Malformed { what }) => assert!(what.contains(expect), "{what}"),
                other => panic!("flags {flags:#x}: {other:?}"),
            }
        }
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
}
