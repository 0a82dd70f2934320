//! The `.qm` container: magic, header, base mesh, embedded stream.
//!
//! | bytes | content |
//! |---|---|
//! | 4 | magic `89 51 4D 0A` (`\x89QM\n`) |
//! | 1 | format version ([`VERSION`]; versions from [`OLDEST`] on are read too) |
//! | 2 | header length `H`, little endian |
//! | `H` | [`Header`]'s fields, then its [`Header::holds`] (byte by byte: `docs/format.md`) |
//! | 4 | CRC-32 of everything above |
//! | 4 | base section length `B`, little endian |
//! | `B` | base mesh: face corners, then the level-0 scaling values without their low bits, predicted and arithmetic-coded (see `basecode`) |
//! | 4 | CRC-32 of the base section |
//! | rest | the embedded EZW stream, to the end of the data |
//!
//! The stream has no length field and no checksum: any prefix of it is a
//! valid, coarser stream. Everything before it is checked, and a cut there is
//! reported with the number of bytes needed.

use serde::{Deserialize, Serialize};

pub use crate::basecode::{BaseSection, OLDEST, VERSION};
use crate::{Error, Result, basecode};

/// Magic bytes at the start of every `.qm` file.
pub const MAGIC: [u8; 4] = [0x89, b'Q', b'M', b'\n'];

/// Largest [`Header::frames`]: parent-quad normals from level
/// `MAX_LEVEL + 1` on, that is never.
pub const MAX_FRAMES: u8 = qm_lift::MAX_LEVEL as u8 - 1;

/// The first level whose frames use parent-quad normals for a
/// [`Header::frames`] value, `None` for world axes.
pub fn parent_frames_from(frames: u8) -> Option<u32> {
    (frames > 0).then_some(frames as u32 + 2)
}

/// Everything a decoder needs besides the base mesh and the stream.
///
/// The fields are written in this order with bincode's standard
/// configuration (see `docs/format.md` for the bytes).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// Quantization bits per coordinate.
    pub bits: u8,
    /// Subdivision levels above the base mesh.
    pub level: u8,
    /// Lifting update rule ([`qm_lift::UpdateRule::code`]).
    pub update: u8,
    /// Weighting bits per level of the bit-plane coder.
    pub weight_bits: u8,
    /// Extra weighting bits of the first (normal) coordinate.
    pub normal_bits: u8,
    /// Details in world axes (0), or in local frames, normal first, whose
    /// normals come from the parent quads from level `frames + 2` on
    /// (`1..=`[`MAX_FRAMES`]).
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
    /// Bits 0 to 4: the low bits of each base value that the stream
    /// carries instead of the base section
    /// ([`qm_ezw::StreamParams::base_bits`]). Bit 5: [`IMPLIED_SPLIT`].
    /// The other bits are reserved and zero.
    pub flags: u32,
    /// Cuts of the stream that decode as a shorter cut. A stream prefix of
    /// `n` bytes with `from < n < to` for a hold `[from, to]` decodes as its
    /// first `from` bytes, because the encoder measured those closer to the
    /// surface than any cut in between (see [`Self::hold_cut`]). Offsets
    /// count stream bytes; the holds are ordered and do not overlap.
    /// Written after the other fields, each as the gap from the last hold's
    /// end and its length.
    #[serde(skip)]
    pub holds: Vec<[u32; 2]>,
    /// With [`COLOUR`] set: the colour stream's parameters and how it is
    /// interleaved with the geometry's, written after the holds.
    #[serde(skip)]
    pub colour: Option<ColourHeader>,
}

/// The colour stream of a file with [`COLOUR`] set: its parameters, and
/// how the file's stream interleaves it with the geometry's
/// (`crate::colour`).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ColourHeader {
    /// Bit planes of the complete colour stream.
    pub planes: u8,
    /// Passes it holds (at most `planes`).
    pub passes: u8,
    /// Weighting bits per level.
    pub weight_bits: u8,
    /// Extra weighting bits of the luma.
    pub luma_bits: u8,
    /// Bits of each base value the colour stream carries: all of them
    /// (each base value less its channel's `base_min` is below
    /// `2^base_bits`).
    pub base_bits: u8,
    /// Per channel, the least base value (luma, orange and green chroma).
    pub base_min: [i32; 3],
    /// Per channel, the greatest base value.
    pub base_max: [i32; 3],
    /// The interleaving: the file's stream is `runs[0][0]` geometry
    /// bytes, then `runs[0][1]` colour bytes, then `runs[1][0]` geometry
    /// bytes and so on; each part is a prefix of its own stream.
    pub runs: Vec<[u32; 2]>,
    /// Levels of colour beyond the geometry's: the colour stream codes one
    /// colour per sample of level `level + finer`. Written after the runs,
    /// as one byte, only with [`FINER_COLOUR`] set (which a value above 0
    /// sets).
    #[serde(skip)]
    pub finer: u8,
}

impl ColourHeader {
    /// What the bit-plane decoder must be told about the colour stream
    /// over `base_vertices` base vertices.
    pub fn stream_params(&self, base_vertices: u32) -> qm_ezw::StreamParams {
        qm_ezw::StreamParams {
            planes: self.planes as u32,
            passes: self.passes as u32,
            weighting: qm_ezw::Weighting {
                bits_per_level: self.weight_bits as u32,
                normal_bits: self.luma_bits as u32,
            },
            base_bits: self.base_bits as u32,
            base_values: base_vertices,
            contexts: qm_ezw::Contexts::Neighbours,
        }
    }
}

/// [`Header::hold_cut`] for ordered, non-overlapping `holds`.
pub fn hold_cut(holds: &[[u32; 2]], n: usize) -> usize {
    let i = holds.partition_point(|h| h[1] as usize <= n);
    match holds.get(i) {
        Some(&[from, _]) if (from as usize) < n => from as usize,
        _ => n,
    }
}

/// The flags' bits that hold the base bits in the stream.
pub const BASE_BITS_MASK: u32 = 0x1f;

/// The flag of a level-0 mesh whose base is a split triangle mesh sent as
/// its corners alone: each edge midpoint and centre is its prediction from
/// them (the mean of its edge's ends, the quadratic through its triangle),
/// made after the stream's low bits of the corners. Files without it are
/// as before; readers that predate it refuse it as a reserved flag.
pub const IMPLIED_SPLIT: u32 = 0x20;

/// The flag of a file with per-sample colours: a [`ColourHeader`] follows
/// the holds, and the stream interleaves the colour stream with the
/// geometry's. Readers that predate it refuse it as a reserved flag.
pub const COLOUR: u32 = 0x40;

/// The flag of a file whose colours are finer than its geometry: a byte
/// after the colour header gives [`ColourHeader::finer`], 1 to
/// [`MAX_FINER_COLOUR`]. Needs [`COLOUR`]; readers that predate it refuse
/// it as a reserved flag.
pub const FINER_COLOUR: u32 = 0x80;

/// Most levels of colour beyond the geometry's.
pub const MAX_FINER_COLOUR: u8 = 6;

/// The browser decoder's memory limit: 512 MiB, an eighth of the largest
/// WebAssembly heap, so that a hostile file cannot crash the tab. Encoders
/// keep files with colour finer than their geometry within it.
pub const BROWSER_DECODE_MEMORY: u64 = 512 << 20;

/// Every flag bit with a meaning.
const KNOWN_FLAGS: u32 = BASE_BITS_MASK | IMPLIED_SPLIT | COLOUR | FINER_COLOUR;

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

    /// Whether the base is a split triangle mesh sent as its corners alone
    /// ([`IMPLIED_SPLIT`]).
    pub fn implied(&self) -> bool {
        self.flags & IMPLIED_SPLIT != 0
    }

    /// What the bit-plane decoder must be told about the stream.
    pub fn stream_params(&self) -> qm_ezw::StreamParams {
        // With the split implied, the corners alone have low bits in the
        // stream; the decoder narrows `base_values` to them.
        let weighting = qm_ezw::Weighting {
            bits_per_level: self.weight_bits as u32,
            normal_bits: self.normal_bits as u32,
        };
        qm_ezw::StreamParams {
            planes: self.planes as u32,
            passes: self.passes as u32,
            weighting,
            base_bits: self.flags & BASE_BITS_MASK,
            base_values: self.base_vertices,
            contexts: qm_ezw::Contexts::Neighbours,
        }
    }
}

/// [`IMPLIED_SPLIT`] is for level 0 alone, from version 4 on (version 3
/// reserved the bit).
fn check_implied(h: &Header, version: u8) -> Result<()> {
    if h.implied() && version < 4 {
        return Err(Error::Malformed {
            what: format!("unknown header flags {IMPLIED_SPLIT:#x} in version {version}"),
        });
    }
    if h.implied() && h.level != 0 {
        return Err(Error::Malformed {
            what: format!("implied base midpoints and centres at level {}", h.level),
        });
    }
    Ok(())
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
    /// The format version (byte 4).
    pub version: u8,
}

fn config() -> bincode::config::Configuration {
    bincode::config::standard()
}

/// The header's bytes as the container stores them (its fields, then its
/// holds, each as the gap from the last hold's end and its length), without
/// any check: [`write`] checks first; a writer of malformed test files
/// calls this alone.
pub fn encode_header(header: &Header) -> Result<Vec<u8>> {
    let encode_error = |e: bincode::error::EncodeError| Error::Malformed {
        what: e.to_string(),
    };
    let mut bytes = bincode::serde::encode_to_vec(header, config()).map_err(encode_error)?;
    let mut end = 0u32;
    let relative: Vec<[u32; 2]> = (header.holds.iter())
        .map(|&[from, to]| {
            let gap = from.wrapping_sub(end);
            end = to;
            [gap, to.wrapping_sub(from)]
        })
        .collect();
    bincode::serde::encode_into_std_write(&relative, &mut bytes, config()).map_err(encode_error)?;
    if let Some(colour) = &header.colour {
        bincode::serde::encode_into_std_write(colour, &mut bytes, config())
            .map_err(encode_error)?;
        if header.flags & FINER_COLOUR != 0 {
            bytes.push(colour.finer);
        }
    }
    Ok(bytes)
}

/// The CRC-32 (ISO-HDLC, as zlib and PNG) of the header and base sections.
/// A 256-entry table: the sections are small, and the larger tables of a
/// faster CRC weighed on the browser decoder's download
/// (docs/decisions/028-checksum-table.md).
pub fn crc32(bytes: &[u8]) -> u32 {
    const CRC: crc::Crc<u32, crc::Table<1>> =
        crc::Crc::<u32, crc::Table<1>>::new(&crc::CRC_32_ISO_HDLC);
    CRC.checksum(bytes)
}

/// Writes a complete container.
pub fn write(header: &Header, base: &BaseSection, stream: &[u8]) -> Result<Vec<u8>> {
    let low_bits = header.stream_params().base_bits;
    check_holds(&header.holds)?;
    let unknown = header.flags & !KNOWN_FLAGS;
    if unknown != 0 {
        return Err(Error::Malformed {
            what: format!("reserved header flags {unknown:#x} set"),
        });
    }
    check_implied(header, VERSION)?;
    if header.colour.is_some() != (header.flags & COLOUR != 0) {
        return Err(Error::Malformed {
            what: "a colour header without the colour flag, or the flag without one".into(),
        });
    }
    let finer = header.colour.as_ref().map_or(0, |c| c.finer);
    if (header.flags & FINER_COLOUR != 0) != (finer > 0) {
        return Err(Error::Malformed {
            what: format!("{finer} finer colour levels, and the flag says otherwise"),
        });
    }
    if base.low_bits != low_bits {
        return Err(Error::Malformed {
            what: format!(
                "{} low base bits in the stream, the flags say {low_bits}",
                base.low_bits
            ),
        });
    }
    let header_bytes = encode_header(header)?;
    let header_len = u16::try_from(header_bytes.len()).map_err(|_| Error::Limit {
        what: "header length (holds)",
        value: header_bytes.len() as u64,
        max: u16::MAX as u64,
    })?;
    let mut out = Vec::with_capacity(64 + stream.len());
    out.extend_from_slice(&MAGIC);
    out.push(VERSION);
    out.extend_from_slice(&header_len.to_le_bytes());
    out.extend_from_slice(&header_bytes);
    out.extend_from_slice(&crc32(&out).to_le_bytes());

    let base_bytes = basecode::encode(&base.faces, &base.values, VERSION, header.implied());
    out.extend_from_slice(&(base_bytes.len() as u32).to_le_bytes());
    out.extend_from_slice(&base_bytes);
    out.extend_from_slice(&crc32(&base_bytes).to_le_bytes());
    out.extend_from_slice(stream);
    Ok(out)
}

/// Most extra weighting bits of the normal coordinate.
pub const MAX_NORMAL_BITS: u8 = 8;

/// Decoder limits on what header fields may ask for, in the manner of
/// image-png's `Limits`: checked against the header alone, before anything
/// is allocated for the mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub struct Limits {
    /// Most base vertices.
    pub max_base_vertices: u32,
    /// Most base faces.
    pub max_base_faces: u32,
    /// Most samples of the decoded mesh.
    pub max_samples: u64,
    /// Most bytes the decoder may allocate for the mesh, its trees and
    /// buffers, as [`decode_memory`] estimates them from the header.
    pub max_memory: u64,
}

/// Bytes a decoder holds per sample, at most: values, layout, the tree and
/// the coder's state, and the output mesh (positions and quads). Measured
/// peaks of `qm decompress` stay below it (`docs/hostile-input.md`).
pub const DECODE_BYTES_PER_SAMPLE: u64 = 160;

/// Bytes a decoder of a file with colours holds per sample of the colour
/// (at the geometry's level, or finer): the colour's layout, values, tree
/// and coder state, the output colours, and the texture of colour finer
/// than the mesh (measured: about 52 bytes a sample of valve-index's
/// finer colour, docs/appearance.md).
pub const COLOUR_BYTES_PER_SAMPLE: u64 = 64;

/// Bytes per base vertex and per base face a decoder holds, at most (the
/// base mesh's adjacency and the section as read).
pub const DECODE_BYTES_PER_BASE_ELEMENT: u64 = 256;

/// The default memory limit of the native decoder: 1 GiB.
pub const DEFAULT_MAX_MEMORY: u64 = 1 << 30;

impl Limits {
    /// Defaults: 4M base vertices and faces, 64M samples, 1 GiB of memory.
    pub const DEFAULT: Limits = Limits {
        max_base_vertices: 1 << 22,
        max_base_faces: 1 << 22,
        max_samples: 1 << 26,
        max_memory: DEFAULT_MAX_MEMORY,
    };

    /// No limits beyond what the format itself can describe: for bytes the
    /// caller wrote itself.
    pub const NONE: Limits = Limits {
        max_base_vertices: u32::MAX,
        max_base_faces: u32::MAX,
        max_samples: u64::MAX,
        max_memory: u64::MAX,
    };

    /// Sets the sample limit.
    pub const fn with_max_samples(mut self, max: u64) -> Self {
        self.max_samples = max;
        self
    }

    /// Sets the memory limit, in bytes.
    pub const fn with_max_memory(mut self, bytes: u64) -> Self {
        self.max_memory = bytes;
        self
    }
}

impl Default for Limits {
    fn default() -> Self {
        Limits::DEFAULT
    }
}

/// Samples of the mesh a header describes (base vertices, then each base
/// face's edge and interior points; shared edges counted twice, so an
/// upper bound).
pub fn sample_count(h: &Header) -> u64 {
    samples_at(h, h.level as u32)
}

/// The level of the colour stream of `h` (with [`COLOUR`]): the geometry's
/// level and [`ColourHeader::finer`] more; the geometry's without colour.
pub fn colour_level(h: &Header) -> u32 {
    h.level as u32 + h.colour.as_ref().map_or(0, |c| c.finer as u32)
}

/// [`sample_count`] of the layout at `level` over `h`'s base.
fn samples_at(h: &Header, level: u32) -> u64 {
    sample_bound(h.base_vertices, h.base_faces, level)
}

/// An upper bound of the samples of a layout at `level` over a base of
/// `vertices` and `faces` (shared edges counted twice).
pub fn sample_bound(vertices: u32, faces: u32, level: u32) -> u64 {
    // Saturating: callers may ask before the level is checked.
    let m = (1u64 << level.min(63)) - 1;
    let per_face = m.saturating_mul(m).saturating_add(m.saturating_mul(4));
    (vertices as u64).saturating_add((faces as u64).saturating_mul(per_face))
}

/// Bytes a decoder of the stream that `h` describes holds at most
/// ([`decode_memory_of`]).
pub fn decode_memory(h: &Header) -> u64 {
    let colour = h.colour.as_ref().map(|_| colour_level(h));
    decode_memory_of(h.base_vertices, h.base_faces, h.level as u32, colour)
}

/// Bytes a decoder holds at most for a base of `vertices` and `faces` at
/// `level`, with colours at `colour` (a level at least as fine) or
/// without: [`DECODE_BYTES_PER_SAMPLE`] a sample of the geometry,
/// [`COLOUR_BYTES_PER_SAMPLE`] a sample of the colour (its own layout,
/// and a texture where it is finer), [`DECODE_BYTES_PER_BASE_ELEMENT`] a
/// base vertex or face.
pub fn decode_memory_of(vertices: u32, faces: u32, level: u32, colour: Option<u32>) -> u64 {
    let base = vertices as u64 + faces as u64;
    let colour = colour.map_or(0, |l| {
        sample_bound(vertices, faces, l).saturating_mul(COLOUR_BYTES_PER_SAMPLE)
    });
    sample_bound(vertices, faces, level)
        .saturating_mul(DECODE_BYTES_PER_SAMPLE)
        .saturating_add(colour)
        .saturating_add(base.saturating_mul(DECODE_BYTES_PER_BASE_ELEMENT))
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
    if !(OLDEST..=VERSION).contains(&version) {
        return Err(Error::UnsupportedVersion {
            found: version,
            newest: VERSION,
        });
    }
    let header_len = u16::from_le_bytes(take(data, 5, 2)?.try_into().expect("2 bytes")) as usize;
    let header_raw = take(data, 7, header_len)?;
    let crc = u32::from_le_bytes(take(data, 7 + header_len, 4)?.try_into().expect("4 bytes"));
    if crc != crc32(&data[..7 + header_len]) {
        return Err(Error::Checksum { section: "header" });
    }
    let (header, used): (Header, usize) = decode_part(header_raw, "header")?;
    let (relative, more): (Vec<[u32; 2]>, usize) = decode_part(&header_raw[used..], "header")?;
    let mut used = used + more;
    let colour = if header.flags & COLOUR != 0 {
        let (mut colour, more): (ColourHeader, usize) =
            decode_part(&header_raw[used..], "colour header")?;
        used += more;
        if header.flags & FINER_COLOUR != 0 {
            colour.finer = *header_raw.get(used).ok_or_else(|| Error::Malformed {
                what: "colour header: no finer colour levels".into(),
            })?;
            used += 1;
        }
        Some(colour)
    } else if header.flags & FINER_COLOUR != 0 {
        return Err(Error::Malformed {
            what: "finer colour levels without colour".into(),
        });
    } else {
        None
    };
    if used != header_raw.len() {
        return Err(Error::Malformed {
            what: format!("header: {} trailing bytes", header_raw.len() - used),
        });
    }
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
    let header = Header {
        holds,
        colour,
        ..header
    };
    let header_bytes = 7 + header_len + 4;
    check_header(&header, limits)?;
    check_implied(&header, version)?;

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
    if crc != crc32(base_raw) {
        return Err(Error::Checksum {
            section: "base mesh",
        });
    }
    let low_bits = header.stream_params().base_bits;
    let base = basecode::decode(
        base_raw,
        header.base_faces as usize,
        header.base_vertices as usize,
        low_bits,
        version,
        header.implied(),
    )
    .map_err(|problem| Error::Malformed {
        what: format!("base mesh: {problem}"),
    })?;
    let base_bytes = 4 + base_len + 4;
    Ok(Container {
        header,
        base,
        stream: &data[header_bytes + base_bytes..],
        header_bytes,
        base_bytes,
        version,
    })
}

/// The high part a base value `v` is stored as when the stream holds its
/// low `k` bits: rounded, `(v + 2^(k-1)) >> k`, from format version 5 on
/// ([`qm_ezw::BaseBits::rounded`]); the stream's low bits are those of
/// `v + 2^(k-1)`.
pub fn rounded_high(v: i32, k: u32) -> i32 {
    (v + base_offset(VERSION, k)) >> k
}

/// What a decoder subtracts from a base value made of its high part and
/// the stream's low `k` bits: half their step from format version 5 on
/// (where the high parts are rounded), else 0.
pub fn base_offset(version: u8, k: u32) -> i32 {
    if version >= 5 && k > 0 {
        1 << (k - 1)
    } else {
        0
    }
}

/// The value at the start of `raw`, and the bytes it took.
fn decode_part<T: serde::de::DeserializeOwned>(raw: &[u8], what: &str) -> Result<(T, usize)> {
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
    Ok((value, used))
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

/// The colour header's planes fit its values and weights, its base bits
/// have planes, and its runs count at most 2^32 - 1 bytes of each stream.
fn check_colour(c: &ColourHeader, flags: u32, level: u8) -> Result<()> {
    let malformed = |what: String| Err(Error::Malformed { what });
    if (flags & FINER_COLOUR != 0) != (c.finer > 0) || c.finer > MAX_FINER_COLOUR {
        return malformed(format!("{} finer colour levels", c.finer));
    }
    if level as u32 + c.finer as u32 > qm_lift::MAX_LEVEL {
        return malformed(format!(
            "colour at level {} beyond {}",
            level as u32 + c.finer as u32,
            qm_lift::MAX_LEVEL
        ));
    }
    // The colour's weights and planes count its own levels.
    let level = level + c.finer;
    if c.weight_bits > 2 || c.luma_bits > MAX_NORMAL_BITS {
        return malformed(format!(
            "colour weights of {} and {} bits",
            c.weight_bits, c.luma_bits
        ));
    }
    let most_planes =
        crate::colour::VALUE_BITS + 8 + c.weight_bits as u32 * level as u32 + c.luma_bits as u32;
    if c.planes as u32 > most_planes || c.passes > c.planes {
        return malformed(format!("{} colour passes of {} planes", c.passes, c.planes));
    }
    let params = c.stream_params(0);
    let most = params
        .weighting
        .max_base_bits(c.planes as u32, level as u32);
    if c.base_bits as u32 > most.min(crate::colour::VALUE_BITS) {
        return malformed(format!(
            "{} colour base bits in the stream, which has planes for {most}",
            c.base_bits
        ));
    }
    for k in 0..3 {
        let span = c.base_max[k] as i64 - c.base_min[k] as i64;
        if !(0..1 << c.base_bits).contains(&span) {
            return malformed(format!(
                "colour base values from {} to {} in {} bits",
                c.base_min[k], c.base_max[k], c.base_bits
            ));
        }
    }
    let mut totals = [0u64; 2];
    for run in &c.runs {
        for (total, &n) in totals.iter_mut().zip(run) {
            *total += n as u64;
        }
    }
    if totals.iter().any(|&t| t > u32::MAX as u64) {
        return malformed("colour interleaving beyond 4 GiB".into());
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
    if h.flags & !KNOWN_FLAGS != 0 {
        return Err(Error::Malformed {
            what: format!("unknown header flags {:#x}", h.flags & !KNOWN_FLAGS),
        });
    }
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
    if let Some(colour) = &h.colour {
        check_colour(colour, h.flags, h.level)?;
    }
    if !(h.step.is_finite() && h.step > 0.0 && h.origin.iter().all(|x| x.is_finite())) {
        return Err(Error::Malformed {
            what: "quantization origin or step is not finite".into(),
        });
    }
    // Upper bounds of the sample count and the memory before anything is
    // allocated.
    let samples = samples_at(h, colour_level(h));
    limit("sample count", samples, limits.max_samples)?;
    let needed = decode_memory(h);
    if needed > limits.max_memory {
        return Err(Error::Memory {
            needed,
            limit: limits.max_memory,
            samples,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests;
