//! `cargo xtask corpus`: writes the malformed `.qm` files of
//! `tests/corrupt/` anew from one valid stream, and prints their rows of
//! `tests/corrupt/README.md`.
//!
//! The valid stream is `assets/quad/holed_grid_l4.obj` compressed at 10 bits
//! with the defaults; the decompression bombs also start from
//! `assets/quad/cc_cube.obj` at 16 bits. Each file changes one thing; where a field is changed
//! on purpose, the checksum over it is recomputed so that the check behind
//! the checksum is reached. Each file's expected error fragment is checked
//! against what the decoder says before the file is written.

use std::path::Path;

use qm::codec::container::{self, Header, MAGIC};

/// A valid stream, split into its sections.
struct Valid {
    bytes: Vec<u8>,
    header: Header,
    /// Bytes of magic, version, length, header and its checksum.
    header_bytes: usize,
    /// Bytes of the base section with its length and checksum.
    base_bytes: usize,
}

impl Valid {
    /// The bundled quad mesh `name` compressed at `bits` with the defaults.
    fn new(name: &str, bits: u32) -> Result<Valid, String> {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/quad");
        let mesh = qm::read_mesh(dir.join(name)).map_err(|e| e.to_string())?;
        let prepared = qm::detect(&mesh).map_err(|e| e.to_string())?;
        let options = qm::EncodeOptions::DEFAULT.with_bits(bits);
        let bytes = qm::codec::compress(&prepared.mesh, &options)
            .map_err(|e| e.to_string())?
            .bytes;
        let c = container::read(&bytes, &qm::Limits::DEFAULT).map_err(|e| e.to_string())?;
        let (header, header_bytes, base_bytes) = (c.header, c.header_bytes, c.base_bytes);
        Ok(Valid {
            bytes,
            header,
            header_bytes,
            base_bytes,
        })
    }

    /// The raw base section (without its length and checksum).
    fn base(&self) -> &[u8] {
        &self.bytes[self.header_bytes + 4..self.header_bytes + self.base_bytes - 4]
    }

    /// The stream after the base section.
    fn stream(&self) -> &[u8] {
        &self.bytes[self.header_bytes + self.base_bytes..]
    }

    /// The header's raw bytes (fields and holds, without the framing).
    fn header_raw(&self) -> &[u8] {
        &self.bytes[7..self.header_bytes - 4]
    }

    /// This stream with header `h` (fields written as they are, unchecked)
    /// and a valid header checksum.
    fn with_header(&self, h: &Header) -> Vec<u8> {
        let raw = container::encode_header(h).expect("a header encodes");
        self.with_header_raw(container::VERSION, &raw)
    }

    /// This stream with its header changed by `change` (unchecked) and a
    /// valid header checksum.
    fn changed(&self, change: &dyn Fn(&mut Header)) -> Vec<u8> {
        let mut h = self.header.clone();
        change(&mut h);
        self.with_header(&h)
    }

    /// This stream with version byte `version`, raw header bytes `raw` and
    /// a valid header checksum.
    fn with_header_raw(&self, version: u8, raw: &[u8]) -> Vec<u8> {
        let mut out = MAGIC.to_vec();
        out.push(version);
        out.extend_from_slice(&(raw.len() as u16).to_le_bytes());
        out.extend_from_slice(raw);
        out.extend_from_slice(&qm::codec::container::crc32(&out).to_le_bytes());
        out.extend_from_slice(&self.bytes[self.header_bytes..]);
        out
    }

    /// This stream with base section `base` (its length and checksum
    /// valid).
    fn with_base(&self, base: &[u8]) -> Vec<u8> {
        let mut out = self.bytes[..self.header_bytes].to_vec();
        out.extend_from_slice(&(base.len() as u32).to_le_bytes());
        out.extend_from_slice(base);
        out.extend_from_slice(&qm::codec::container::crc32(base).to_le_bytes());
        out.extend_from_slice(self.stream());
        out
    }

    /// This stream with byte `at` xored with `mask`.
    fn flipped(&self, at: usize, mask: u8) -> Vec<u8> {
        let mut out = self.bytes.clone();
        out[at] ^= mask;
        out
    }
}

/// One corpus file: name, what is wrong, the bytes, the expected fragment.
struct Case {
    file: &'static str,
    what: String,
    bytes: Vec<u8>,
    fragment: String,
}

fn case(file: &'static str, what: &str, bytes: Vec<u8>, fragment: &str) -> Case {
    Case {
        file,
        what: what.to_string(),
        bytes,
        fragment: fragment.to_string(),
    }
}

/// Decompression bombs: a few kilobytes whose header asks for gigabytes,
/// checksums valid. `cube` is cc_cube at 16 bits, `v` the holed grid.
fn bombs(cube: &Valid, v: &Valid) -> Vec<Case> {
    vec![
        case(
            "qm-bomb-level-11.qm",
            "cc_cube (6 base quads, level 5) with its level raised to 11: 25M samples",
            cube.changed(&|h| h.level = 11),
            "needs about 3844 MiB of memory for 25190390 samples, above the limit of 1024 MiB",
        ),
        case(
            "qm-bomb-level-12.qm",
            "cc_cube with its level raised to 12: 100M samples",
            cube.changed(&|h| h.level = 12),
            "sample count is 100712438, above the limit of 67108864",
        ),
        case(
            "qm-bomb-base-faces.qm",
            "the holed grid (level 4) claiming 100,000 base faces",
            v.changed(&|h| h.base_faces = 100_000),
            "above the limit of 1024 MiB",
        ),
        case(
            "qm-bomb-base-vertices.qm",
            "the holed grid claiming 4,000,000 base vertices",
            v.changed(&|h| h.base_vertices = 4_000_000),
            "above the limit of 1024 MiB",
        ),
    ]
}

fn cases(v: &Valid) -> Vec<Case> {
    let hb = v.header_bytes;
    let base_len = v.base().len();
    let mut crlf = b"\x89QM\r\n".to_vec();
    crlf.extend_from_slice(&v.bytes[4..]);
    let mut zip = b"PK\x03\x04".to_vec();
    zip.extend_from_slice(&v.bytes[4..]);
    let mut trailing = v.header_raw().to_vec();
    trailing.extend_from_slice(&[0, 0, 0]);
    let mut huge_header = v.bytes.clone();
    huge_header[5..7].copy_from_slice(&u16::MAX.to_le_bytes());
    let mut huge_base = v.bytes.clone();
    huge_base[hb..hb + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    vec![
        case(
            "qm-empty.qm",
            "zero bytes",
            Vec::new(),
            "0 bytes, at least 4 needed",
        ),
        case(
            "qm-magic-only.qm",
            "only the four magic bytes",
            MAGIC.to_vec(),
            "4 bytes, at least 5 needed",
        ),
        case(
            "qm-bad-magic.qm",
            "a zip signature instead of the magic",
            zip,
            "bad magic bytes",
        ),
        case(
            "qm-text-mode-crlf.qm",
            "the magic's newline became CR LF",
            crlf,
            "bad magic bytes",
        ),
        case(
            "qm-version-0.qm",
            "version byte 0, below the first published version (header checksum valid)",
            v.with_header_raw(0, v.header_raw()),
            "format version 0 is not supported",
        ),
        case(
            "qm-version-7.qm",
            "version byte 7, a version that does not exist yet (header checksum valid)",
            v.with_header_raw(7, v.header_raw()),
            "format version 7 is not supported",
        ),
        case(
            "qm-header-frames-12.qm",
            "frame kind 12 (0 to 11 exist)",
            v.changed(&|h| h.frames = 12),
            "unknown frame kind 12",
        ),
        case(
            "qm-header-normal-bits-9.qm",
            "normal weight of 9 bits",
            v.changed(&|h| h.normal_bits = 9),
            "normal weight of 9 bits",
        ),
        case(
            "qm-header-flag-0x40.qm",
            "reserved header flag bit 6 set",
            v.changed(&|h| h.flags |= 0x40),
            "unknown header flags 0x40",
        ),
        case(
            "qm-header-flag-0x20.qm",
            "implied-split flag (bit 5) on a level-4 file",
            v.changed(&|h| h.flags |= 0x20),
            "implied base midpoints and centres at level 4",
        ),
        case(
            "qm-header-empty-hold.qm",
            "one hold, empty: `[5, 5]`",
            v.changed(&|h| h.holds = vec![[5, 5]]),
            "hold [5, 5] after one ending at 0",
        ),
        case(
            "qm-cut-in-header.qm",
            "cut after 30 bytes, inside the header",
            v.bytes[..30].to_vec(),
            "truncated inside the header",
        ),
        case(
            "qm-cut-before-base-length.qm",
            "cut right after the header checksum",
            v.bytes[..hb].to_vec(),
            &format!("at least {} needed", hb + 4),
        ),
        case(
            "qm-cut-in-base.qm",
            "cut inside the base section",
            v.bytes[..hb + 4 + base_len / 2].to_vec(),
            "truncated inside the header or base mesh",
        ),
        case(
            "qm-cut-in-base-crc.qm",
            "cut inside the base checksum",
            v.bytes[..hb + 4 + base_len + 2].to_vec(),
            &format!("at least {} needed", hb + base_len + 8),
        ),
        case(
            "qm-header-bit-flipped.qm",
            "one bit of the quantization origin flipped",
            v.flipped(7 + 6 + 3, 0x10),
            "the header is corrupt",
        ),
        case(
            "qm-header-crc-flipped.qm",
            "a byte of the header checksum flipped",
            v.flipped(hb - 2, 0x01),
            "the header is corrupt",
        ),
        case(
            "qm-header-length-huge.qm",
            "header length 65535",
            huge_header,
            "at least 65542 needed",
        ),
        case(
            "qm-header-length-zero.qm",
            "header length 0, checksum valid",
            v.with_header_raw(container::VERSION, &[]),
            "malformed stream: header",
        ),
        case(
            "qm-header-trailing-bytes.qm",
            "three extra bytes in the header, checksum valid",
            v.with_header_raw(container::VERSION, &trailing),
            "header: 3 trailing bytes",
        ),
        case(
            "qm-header-bits-0.qm",
            "0 quantization bits",
            v.changed(&|h| h.bits = 0),
            "0 quantization bits",
        ),
        case(
            "qm-header-bits-30.qm",
            "30 quantization bits",
            v.changed(&|h| h.bits = 30),
            "30 quantization bits",
        ),
        case(
            "qm-header-level-13.qm",
            "subdivision level 13",
            v.changed(&|h| h.level = 13),
            "subdivision level is 13",
        ),
        case(
            "qm-header-update-9.qm",
            "update rule 9",
            v.changed(&|h| h.update = 9),
            "unknown update rule 9",
        ),
        case(
            "qm-header-passes-above-planes.qm",
            "9 passes of 7 planes",
            v.changed(&|h| (h.passes, h.planes) = (9, 7)),
            "9 passes of 7 planes",
        ),
        case(
            "qm-header-step-nan.qm",
            "quantization step NaN",
            v.changed(&|h| h.step = f64::NAN),
            "not finite",
        ),
        case(
            "qm-header-step-zero.qm",
            "quantization step 0",
            v.changed(&|h| h.step = 0.0),
            "quantization origin or step",
        ),
        case(
            "qm-header-origin-infinite.qm",
            "infinite origin",
            v.changed(&|h| h.origin[1] = f64::INFINITY),
            "not finite",
        ),
        case(
            "qm-header-base-vertices-huge.qm",
            "2^32-1 base vertices",
            v.changed(&|h| h.base_vertices = u32::MAX),
            "above the limit",
        ),
        case(
            "qm-header-base-faces-huge.qm",
            "2^23 base faces (the default limit is 2^22)",
            v.changed(&|h| h.base_faces = 1 << 23),
            "above the limit",
        ),
        case(
            "qm-header-samples-above-limit.qm",
            "100 base faces at level 12",
            v.changed(&|h| (h.base_faces, h.level) = (100, 12)),
            "sample count",
        ),
        case(
            "qm-header-vertex-count-mismatch.qm",
            "header says one base vertex more than the base section holds",
            v.changed(&|h| h.base_vertices += 1),
            "base mesh",
        ),
        case(
            "qm-base-bit-flipped.qm",
            "one bit of the base section flipped",
            v.flipped(hb + 4 + base_len / 2, 0x04),
            "the base mesh is corrupt",
        ),
        case(
            "qm-base-crc-flipped.qm",
            "one bit of the base checksum flipped",
            v.flipped(hb + 4 + base_len + 1, 0x08),
            "the base mesh is corrupt",
        ),
        case(
            "qm-base-length-huge.qm",
            "base section length 2^32-1",
            huge_base,
            "base section length",
        ),
        case(
            "qm-base-truncated-with-valid-crc.qm",
            "base section cut to 20 bytes, checksum valid",
            v.with_base(&v.base()[..20]),
            "malformed stream: base mesh",
        ),
    ]
}

/// Writes the files into `tests/corrupt/` and prints their table rows.
pub fn run(args: &[String]) -> Result<(), String> {
    if !args.is_empty() {
        return Err("usage: cargo xtask corpus".into());
    }
    let valid = Valid::new("holed_grid_l4.obj", 10)?;
    let cube = Valid::new("cc_cube.obj", 16)?;
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/corrupt");
    println!(
        "valid stream: {} bytes (header {}, base {}, stream {})",
        valid.bytes.len(),
        valid.header_bytes,
        valid.base_bytes,
        valid.stream().len()
    );
    let mut wrong = Vec::new();
    for c in cases(&valid).into_iter().chain(bombs(&cube, &valid)) {
        let said = match qm::decode(&c.bytes, &qm::DecodeOptions::default()) {
            Ok(_) => "decodes".to_string(),
            Err(e) => e.to_string(),
        };
        if !said.contains(&c.fragment) {
            wrong.push(format!(
                "{}: expected `{}`, got `{said}`",
                c.file, c.fragment
            ));
        }
        std::fs::write(dir.join(c.file), &c.bytes).map_err(|e| format!("{}: {e}", c.file))?;
        println!("| `{}` | {} | `{}` |", c.file, c.what, c.fragment);
        eprintln!("  {}: {said}", c.file);
    }
    if wrong.is_empty() {
        Ok(())
    } else {
        Err(wrong.join("\n"))
    }
}
