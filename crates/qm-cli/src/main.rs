//! The `qm` command line: compress, decompress and inspect `.qm` files, and
//! measure how far two meshes are apart.
//!
//! Exit status: 0 on success; on failure one line `error: ...` on stderr
//! naming the file and the problem, and a status saying whose fault it is
//! (`output::Failure::exit_code`): 1 the input or a file, 2 the arguments
//! (clap's usage errors too), 3 a limit the caller may raise, 4 a bug.

/// `println!` without its panic: where stdout is closed early (`qm info
/// x.qm | head -3`) the process ends quietly, as `head` expects, and any
/// other failure to write is an error.
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::write_out(format_args!($($arg)*))
    };
}

/// `eprintln!` without its panic: a note that cannot be written is dropped.
macro_rules! note {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

mod inspect;
mod output;
mod parse;
mod serve;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};

use output::{Failure, Progress, check_output, default_output, write_atomic};
use parse::{level_choice, memory_size, non_negative, on_off, seconds};

#[derive(Parser)]
#[command(
    name = "qm",
    version,
    about = "Progressive mesh compression: any prefix of a .qm stream decodes"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// The remesher's settings, shared by `compress` and `remesh`.
#[derive(Args)]
struct RemeshArgs {
    /// Subdivision level when the input must be remeshed (default: about
    /// 30 samples per input vertex, at most 32).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=qm::lift::MAX_LEVEL as i64))]
    level: Option<u32>,
    /// Place the remeshed samples so that their details are normal
    /// (a normal mesh, see docs/normal-placement.md; default: on).
    #[arg(long, value_name = "on|off", value_parser = on_off)]
    normal_remesh: Option<bool>,
    /// Most memory remeshing and encoding may take, e.g. 512M or 8G
    /// (default 4G); work that would need more is refused before it
    /// starts.
    #[arg(long, value_name = "SIZE", value_parser = memory_size)]
    max_memory: Option<u64>,
    /// Remesh even where a part's map onto its base domain folds (the
    /// remesh then overlaps itself or skips a little of the input there);
    /// by default that is an error.
    #[arg(long)]
    accept_folds: bool,
    /// How the base domain is made: one square per part, a simplified
    /// base domain of many charts, or the input's own triangles at level 0
    /// (exact, nothing to stream); auto makes and measures the first two,
    /// takes the charts where one square fails or measures 2 dB worse, and
    /// takes the input's triangles for an input of at most 20,000 whose
    /// remesh fails or measures below 80 dB (see docs/remesher-next.md);
    /// `compress` then weighs a kept remesh of such an input against its
    /// own triangles by the bytes each stream needs for 65 and 78 dB.
    #[arg(long, value_enum, default_value_t = Domain::Auto)]
    base_domain: Domain,
    /// Refuse a remesh through a simplified base domain that measures
    /// below this PSNR against the input (0 accepts any).
    #[arg(long, value_name = "DB", default_value_t = qm::param::remesh::DEFAULT_MIN_PSNR)]
    min_remesh_psnr: f64,
}

/// `--base-domain`.
#[derive(Clone, Copy, clap::ValueEnum)]
enum Domain {
    Auto,
    Square,
    Charts,
    Input,
}

impl RemeshArgs {
    /// The remesher's defaults with these settings.
    fn options(&self) -> qm::RemeshOptions {
        let defaults = qm::RemeshOptions::DEFAULT;
        defaults
            .with_level(self.level)
            .with_normal(self.normal_remesh.unwrap_or(defaults.normal))
            .with_max_memory(self.max_memory.unwrap_or(defaults.max_memory))
            .with_accept_folds(self.accept_folds)
            .with_domain(match self.base_domain {
                Domain::Auto => qm::param::BaseDomain::Auto,
                Domain::Square => qm::param::BaseDomain::Square,
                Domain::Charts => qm::param::BaseDomain::Charts,
                Domain::Input => qm::param::BaseDomain::Input,
            })
            .with_min_psnr(self.min_remesh_psnr)
    }
}

#[derive(Subcommand)]
enum Command {
    /// Compress a mesh (OBJ, PLY, OFF, STL, glTF, GLB) into a .qm stream,
    /// with its vertex colours or base colour texture. What the stream
    /// cannot carry (texture coordinates and images as given, normals, other
    /// maps, ...) is named on stderr, one warning a kind.
    Compress {
        /// Input mesh.
        input: PathBuf,
        /// Output file (default: the input with extension .qm).
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Quantization bits per coordinate.
        #[arg(long, default_value_t = qm::lift::DEFAULT_BITS, value_parser = clap::value_parser!(u32).range(qm::lift::MIN_BITS as i64..=qm::lift::MAX_BITS as i64))]
        bits: u32,
        /// Code at most this many bit-plane passes (default: all, lossless).
        #[arg(long)]
        passes: Option<u32>,
        /// Cut the file to at most this many bytes.
        #[arg(long)]
        bytes: Option<usize>,
        #[command(flatten)]
        remesh: RemeshArgs,
        /// Code the details in world axes, the three coordinates alike,
        /// instead of normal first in local frames (can suit dense noisy
        /// scans; see docs/frames.md).
        #[arg(long)]
        no_frames: bool,
        /// Local frames take their normals from the parent quads from this
        /// level on (default: 3 or 4, whichever codes the mesh better, or a
        /// later one if it codes it clearly better still; giving it skips
        /// the extra encodings).
        #[arg(long, conflicts_with = "no_frames", value_parser = clap::value_parser!(u32).range(3..=qm::lift::MAX_LEVEL as i64 + 1))]
        frames_from: Option<u32>,
        /// Write no holds (default: the encoder decodes its stream at many
        /// cuts and makes a cut that would decode worse than a shorter one
        /// decode as the shorter one; costs encoding time and a few header
        /// bytes per hold; see docs/holds.md).
        #[arg(long)]
        no_holds: bool,
        /// Code the geometry alone, without the input's colours or texture
        /// (default: a mesh with vertex colours or a base colour texture
        /// gets one colour per sample, coded with the geometry).
        #[arg(long)]
        geometry_only: bool,
        /// Print a JSON summary on stdout: sizes, the base domain taken and
        /// why (`base_domain`, `base_domain_why`), the list of what was
        /// not carried (`dropped`), and each step's wall time (`seconds`).
        #[arg(long)]
        json: bool,
        /// No progress, summary or warning output (--json still lists what
        /// was not carried).
        #[arg(long)]
        quiet: bool,
    },
    /// Remesh any mesh into a semi-regular quad mesh and write it.
    Remesh {
        /// Input mesh.
        input: PathBuf,
        /// Output mesh, .obj or .ply (default: the input name + "-remeshed.obj").
        #[arg(short, long)]
        output: Option<PathBuf>,
        #[command(flatten)]
        remesh: RemeshArgs,
        /// No progress or summary output.
        #[arg(long)]
        quiet: bool,
    },
    /// Decompress a .qm stream (or a prefix of one) into a mesh.
    Decompress {
        /// Input .qm file.
        input: PathBuf,
        /// Output mesh, .obj, .ply or .glb (default: the input with extension
        /// .obj); a texture is written beside an .obj (.mtl, .png) and into
        /// a .glb.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Use only the first N bytes, as if the rest never arrived.
        #[arg(long)]
        bytes: Option<usize>,
        /// Decode at most this many passes.
        #[arg(long)]
        passes: Option<u32>,
        /// Output level: `auto` (the coarsest level within --tolerance of
        /// the finest one's estimated error at this prefix: the level the
        /// bytes support), `finest`, or a number (0 = base mesh).
        #[arg(long, default_value = "auto", value_parser = level_choice)]
        level: qm::LevelChoice,
        /// Stop at the first pass whose estimated RMS error (model units)
        /// is at most this, using no more of the file.
        #[arg(long, value_name = "RMS", value_parser = non_negative)]
        max_error: Option<f64>,
        /// Output no level with more triangles than this.
        #[arg(long, value_name = "N")]
        max_triangles: Option<u64>,
        /// How much worse, in dB of estimated PSNR, `--level auto` may be
        /// than the finest level at the same prefix.
        #[arg(long, value_name = "DB", default_value_t = qm::codec::DEFAULT_TOLERANCE_DB, value_parser = non_negative)]
        tolerance: f64,
        /// Most memory the decoder may take, e.g. 512M or 8G (default 1G);
        /// a file that asks for more is refused before anything is
        /// allocated.
        #[arg(long, value_name = "SIZE", value_parser = memory_size)]
        max_memory: Option<u64>,
        /// No progress or summary output.
        #[arg(long)]
        quiet: bool,
    },
    /// Write a .qm file as glTF with the extension QM_progressive_mesh: a
    /// coarse fallback mesh any glTF viewer shows, and the .qm (embedded in
    /// a .glb, or at --uri) that qm's loaders stream.
    Gltf {
        /// Input .qm file.
        input: PathBuf,
        /// Output .glb, or .gltf (one JSON file pointing at the .qm: --uri,
        /// by default the input's file name) (default: the input with
        /// extension .glb).
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Leave the .qm out of the GLB and point at this URI (relative to
        /// the GLB) instead, so that clients fetch it by byte ranges.
        #[arg(long)]
        uri: Option<String>,
        /// The fallback's level (default: the finest with at most
        /// --fallback-triangles triangles).
        #[arg(long, value_parser = clap::value_parser!(u32).range(0..=qm::lift::MAX_LEVEL as i64))]
        fallback_level: Option<u32>,
        /// Most triangles of the default fallback level.
        #[arg(long, default_value_t = qm::gltf::DEFAULT_FALLBACK_TRIANGLES)]
        fallback_triangles: u64,
        /// Decode the fallback from the first N bytes (default: the fewest
        /// that support its level).
        #[arg(long, value_name = "N")]
        fallback_bytes: Option<usize>,
        /// No summary output.
        #[arg(long)]
        quiet: bool,
    },
    /// Describe a .qm file.
    Info {
        /// Input .qm file.
        input: PathBuf,
        /// Also list what each prefix ending at a pass decodes to: its bytes,
        /// the level the bytes support, triangles and estimated error
        /// (decodes the whole file).
        #[arg(long)]
        levels: bool,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
    /// Measure the symmetric surface distance between two meshes (as Metro
    /// does): RMS, mean and Hausdorff distance, and PSNR over A's bounding
    /// box diagonal; when both carry vertex colours or a texture, also the
    /// colour PSNR over 8-bit RGB at the same samples.
    Distance {
        /// First mesh; its bounding box diagonal is the PSNR peak.
        a: PathBuf,
        /// Second mesh.
        b: PathBuf,
        /// Print JSON (PSNR of identical surfaces, infinite, is null).
        #[arg(long)]
        json: bool,
        /// Area-uniform samples on each surface.
        #[arg(long, default_value_t = qm::param::distance::DEFAULT_SAMPLES, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..))]
        samples: usize,
        /// Sampling seed.
        #[arg(long, default_value_t = qm::param::distance::DEFAULT_SEED)]
        seed: u64,
    },
    /// Serve the browser viewer and model files on 127.0.0.1, with byte
    /// ranges for progressive streaming (see docs/serve.md).
    Serve {
        /// A .qm, .glb or .gltf file, or a folder whose .qm, .glb and .gltf
        /// files (and the .bin files beside a .gltf) are offered.
        path: PathBuf,
        /// TCP port (0: any free port; the URL is printed).
        #[arg(long, default_value_t = 8000)]
        port: u16,
        /// Send model files at most this fast, in KB/s, to watch the progression.
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
        throttle: Option<u32>,
        /// The built viewer (default: web/dist of this source tree).
        #[arg(long)]
        web: Option<PathBuf>,
        /// Seconds a connection may take to send a request head, or stay
        /// idle between requests, or leave a piece of a response untaken.
        #[arg(long, value_name = "SECS", default_value_t = serve::DEFAULT_TIMEOUT, value_parser = seconds)]
        timeout: f64,
        /// No log lines (the URL is still printed).
        #[arg(long)]
        quiet: bool,
    },
}

/// [`out!`]'s line.
fn write_out(line: std::fmt::Arguments) {
    use std::io::Write as _;
    if let Err(e) = writeln!(std::io::stdout().lock(), "{line}") {
        qm::io::remove_partial_outputs();
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        let _ = writeln!(std::io::stderr(), "error: cannot write to stdout: {e}");
        std::process::exit(1);
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // Interrupt, terminate, hang-up: no half-written output left behind.
    let _ = ctrlc::set_handler(|| {
        qm::io::remove_partial_outputs();
        note!("interrupted");
        std::process::exit(130);
    });
    // Past a file-size limit (`ulimit -f`) a write then fails with an error
    // the output's clean-up handles, instead of the signal ending the
    // process with the temporary file left.
    #[cfg(unix)]
    let _ = signal_hook::flag::register(
        signal_hook::consts::SIGXFSZ,
        std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false)),
    );
    let result = match cli.command {
        Command::Compress {
            input,
            output,
            bits,
            passes,
            bytes,
            remesh,
            no_frames,
            frames_from,
            no_holds,
            geometry_only,
            json,
            quiet,
        } => {
            let mut options = qm::EncodeOptions::DEFAULT
                .with_bits(bits)
                .with_passes(passes)
                .with_max_bytes(bytes)
                .with_holds(!no_holds);
            if no_frames {
                options = options
                    .with_frames(false)
                    .with_weighting(qm::Weighting::LEVELS);
            }
            if let Some(level) = frames_from {
                options = options.with_frame_source(qm::Frames::ParentsFrom(level));
            }
            let what = Compression {
                options,
                remesh: remesh.options(),
                colour: !geometry_only,
            };
            compress(&input, output, &what, json, quiet)
        }
        Command::Remesh {
            input,
            output,
            remesh: args,
            quiet,
        } => remesh(&input, output, &args.options(), quiet),
        Command::Decompress {
            input,
            output,
            bytes,
            passes,
            level,
            max_error,
            max_triangles,
            tolerance,
            max_memory,
            quiet,
        } => {
            let limits = max_memory.map_or(qm::Limits::DEFAULT, |m| {
                qm::Limits::DEFAULT.with_max_memory(m)
            });
            let options = qm::DecodeOptions::default()
                .with_limits(limits)
                .with_max_bytes(bytes)
                .with_passes(passes)
                .with_level(level)
                .with_max_error(max_error)
                .with_max_triangles(max_triangles)
                .with_tolerance_db(tolerance);
            decompress(&input, output, &options, quiet)
        }
        Command::Gltf {
            input,
            output,
            uri,
            fallback_level,
            fallback_triangles,
            fallback_bytes,
            quiet,
        } => {
            let options = qm::gltf::GltfOptions::default()
                .with_uri(uri)
                .with_fallback_level(fallback_level)
                .with_fallback_triangles(Some(fallback_triangles))
                .with_fallback_bytes(fallback_bytes);
            gltf(&input, output, &options, quiet)
        }
        Command::Info {
            input,
            levels,
            json,
        } => inspect::info(&input, levels, json),
        Command::Distance {
            a,
            b,
            json,
            samples,
            seed,
        } => inspect::distance(&a, &b, json, samples, seed),
        Command::Serve {
            path,
            port,
            throttle,
            web,
            timeout,
            quiet,
        } => serve::serve(serve::ServeOptions {
            path,
            port,
            throttle,
            web,
            timeout: std::time::Duration::from_secs_f64(timeout),
            quiet,
        }),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => {
            note!("error: {failure}");
            ExitCode::from(failure.exit_code())
        }
    }
}

/// What `qm compress --json` prints.
#[derive(serde::Serialize)]
struct CompressSummary {
    input: String,
    output: String,
    bytes: usize,
    header_bytes: usize,
    base_bytes: usize,
    stream_bytes: usize,
    passes: usize,
    samples: usize,
    base_quads: usize,
    level: u32,
    /// The base domain of a remeshed input (`square`, `charts` or `input`;
    /// null for a quad mesh taken as it is).
    base_domain: Option<&'static str>,
    /// Why `auto` took it, where it was not its first choice.
    base_domain_why: Option<String>,
    /// The remesh's PSNR against the input, where it was measured.
    remesh_psnr: Option<f64>,
    /// Whether the stream carries a colour per sample.
    colour: bool,
    /// For colour at a remesh's samples: how well they can show the
    /// input's colour, as PSNR (the colour stream ends within about 1 dB of
    /// it).
    colour_floor_db: Option<f64>,
    /// What the stream does not carry, one entry a kind.
    dropped: Vec<DroppedEntry>,
    /// Wall time of each step, in seconds.
    seconds: StepSeconds,
}

/// Wall time of the steps of `qm compress`, in seconds.
#[derive(serde::Serialize, Clone, Copy, Default)]
struct StepSeconds {
    /// Reading the input file.
    reading: f64,
    /// Making the mesh semi-regular: detection or the remesh, with the
    /// choice between base domains.
    semi_regular: f64,
    /// Lifting and coding (with the frames' choice, the holds and the
    /// colours).
    coding: f64,
    /// Writing the output file.
    writing: f64,
}

impl StepSeconds {
    fn total(&self) -> f64 {
        self.reading + self.semi_regular + self.coding + self.writing
    }
}

/// What `qm compress` is asked to do.
struct Compression {
    options: qm::EncodeOptions,
    remesh: qm::RemeshOptions,
    /// Carry the input's colours, if it has any.
    colour: bool,
}

/// One kind of attribute not carried.
#[derive(serde::Serialize)]
struct DroppedEntry {
    kind: &'static str,
    count: u64,
    detail: String,
}

fn compress(
    input: &Path,
    output: Option<PathBuf>,
    what: &Compression,
    json: bool,
    quiet: bool,
) -> Result<(), Failure> {
    let (options, remesh_options) = (&what.options, &what.remesh);
    let output = output.unwrap_or_else(|| default_output(input, "qm"));
    check_output(input, &output)?;
    let progress = Progress::new(quiet);
    progress.step("reading mesh");
    let mut seconds = StepSeconds::default();
    let mut clock = std::time::Instant::now();
    let mut lap = || {
        std::mem::replace(&mut clock, std::time::Instant::now())
            .elapsed()
            .as_secs_f64()
    };
    // Images are decoded only when their colours are to be carried.
    let reading = qm::AssetOptions::DEFAULT.with_images(what.colour);
    let mut asset = qm::read_asset(input, &reading).map_err(|e| Failure::about(input, e))?;
    if !what.colour {
        // Not carried: listed as the geometry-only stream's losses.
        asset.dropped.extend(asset.held());
        asset.colors = None;
        asset.tex_coords = None;
        asset.materials.clear();
        asset.face_materials = None;
    }
    let coloured = qm::param::ColourSurface::has_appearance(&asset);
    let dropped = qm::not_carried(&asset);
    progress.suspend(|| {
        if !quiet {
            for d in &dropped {
                note!(
                    "warning: {}: {} not carried ({}): {}",
                    input.display(),
                    d.kind,
                    d.count,
                    d.detail
                );
            }
        }
    });
    seconds.reading = lap();
    progress.step("making the mesh semi-regular (subdivision connectivity or remeshing)");
    let remeshing = |step: qm::param::Step| progress.step(format!("remeshing: {step}"));
    let prepared = qm::prepare_asset_reporting(&asset, remesh_options, &remeshing)
        .map_err(|e| Failure::about(input, e))?;
    seconds.semi_regular = lap();
    progress.suspend(|| {
        if let (false, Some(r)) = (quiet, &prepared.remeshed) {
            report_remesh(input, r);
        }
    });
    // Printing the remesh report is no step's.
    lap();
    progress.step(if coloured {
        "lifting and coding, with the colours"
    } else {
        "lifting and coding"
    });
    let compressed = qm::encode_prepared_asset(&prepared, &asset, options)
        .map_err(|e| Failure::about(input, e))?;
    seconds.coding = lap();
    progress.step("writing");
    write_atomic(&output, &compressed.bytes)?;
    seconds.writing = lap();
    progress.finish();
    let total = compressed.bytes.len();
    let stream = total - compressed.header_bytes - compressed.base_bytes;
    if !quiet {
        note!(
            "{}: {} vertices{}, {} base quads x level {} -> {}: {} bytes (header {}, base {}, stream {}), {} passes, in {:.1} s (reading {:.1}, semi-regular {:.1}, coding {:.1}, writing {:.1})",
            input.display(),
            compressed.samples,
            if coloured { " with colours" } else { "" },
            compressed.base_quads,
            compressed.level,
            output.display(),
            total,
            compressed.header_bytes,
            compressed.base_bytes,
            stream,
            compressed.pass_ends.len(),
            seconds.total(),
            seconds.reading,
            seconds.semi_regular,
            seconds.coding,
            seconds.writing,
        );
    }
    if json {
        let summary = CompressSummary {
            input: input.display().to_string(),
            output: output.display().to_string(),
            bytes: total,
            header_bytes: compressed.header_bytes,
            base_bytes: compressed.base_bytes,
            stream_bytes: stream,
            passes: compressed.pass_ends.len(),
            samples: compressed.samples,
            base_quads: compressed.base_quads,
            level: compressed.level,
            base_domain: compressed.remeshed.as_ref().map(|r| r.domain),
            base_domain_why: compressed
                .remeshed
                .as_ref()
                .and_then(|r| r.fallback.clone()),
            remesh_psnr: compressed.remeshed.as_ref().and_then(|r| r.psnr),
            colour: coloured,
            colour_floor_db: compressed.colour_floor_db,
            dropped: dropped
                .into_iter()
                .map(|d| DroppedEntry {
                    kind: d.kind.key(),
                    count: d.count,
                    detail: d.detail,
                })
                .collect(),
            seconds,
        };
        out!(
            "{}",
            serde_json::to_string_pretty(&summary).expect("plain data serializes")
        );
    }
    Ok(())
}

fn remesh(
    input: &Path,
    output: Option<PathBuf>,
    options: &qm::RemeshOptions,
    quiet: bool,
) -> Result<(), Failure> {
    let output = output.unwrap_or_else(|| {
        let stem = input
            .file_stem()
            .map_or("mesh".into(), |s| s.to_string_lossy().into_owned());
        input.with_file_name(format!("{stem}-remeshed.obj"))
    });
    check_output(input, &output)?;
    let progress = Progress::new(quiet);
    progress.step("reading mesh");
    let mesh = qm::read_mesh(input).map_err(|e| Failure::about(input, e))?;
    let remeshing = |step: qm::param::Step| progress.step(format!("remeshing: {step}"));
    let remeshed = qm::param::remesh_reporting(&mesh, options, &remeshing)
        .map_err(|e| Failure::about(input, qm::Error::from(e)))?;
    let layout = remeshed.mesh.layout();
    let quads = layout.quads(layout.level());
    let out = qm::PolyMesh::from_faces(remeshed.mesh.positions().to_vec(), &quads);
    progress.step("writing mesh");
    qm::write_mesh(&output, &out).map_err(|e| Failure::about(&output, e))?;
    progress.finish();
    if !quiet {
        report_remesh(input, &remeshed.report);
        note!(
            "-> {}: {} vertices, {} quads",
            output.display(),
            out.positions.len(),
            out.face_count()
        );
    }
    Ok(())
}

/// The clean-up line and one line per component.
fn report_remesh(input: &Path, r: &qm::RemeshReport) {
    note!("{}: {}", input.display(), r.clean);
    for (i, c) in r.components.iter().enumerate() {
        note!(
            "  component {i}: {} vertices -> {} base quads x level {}, {} extra cuts, stretch {:.3}, {} flipped",
            c.vertices,
            c.base_quads,
            r.level,
            c.extra_cuts,
            c.stretch,
            c.flipped
        );
    }
    if let Some(n) = r.normal {
        note!(
            "  normal placement: {} samples moved onto their normal ray, {} kept their detail",
            n.moved,
            n.kept
        );
    }
    if let Some(why) = &r.fallback {
        note!("  base domain: {}, since {why}", r.domain);
    }
    if let Some(psnr) = r.psnr {
        note!("  remesh measured at {psnr:.1} dB against the input");
    }
}

fn decompress(
    input: &Path,
    output: Option<PathBuf>,
    options: &qm::DecodeOptions,
    quiet: bool,
) -> Result<(), Failure> {
    let output = output.unwrap_or_else(|| default_output(input, "obj"));
    check_output(input, &output)?;
    match qm::io::Format::from_path(&output) {
        Some(qm::io::Format::Obj | qm::io::Format::Ply | qm::io::Format::Glb) => {}
        _ => {
            return Err(Failure::parameter(format!(
                "{}: output must be .obj, .ply or .glb",
                output.display()
            )));
        }
    }
    let progress = Progress::new(quiet);
    progress.step("reading stream");
    let data = std::fs::read(input).map_err(|e| Failure::about(input, e))?;
    progress.step("decoding");
    let decoded = qm::decode(&data, options).map_err(|e| Failure::about(input, e))?;
    progress.step("writing mesh");
    qm::write_decoded(&output, &decoded).map_err(|e| Failure::about(&output, e))?;
    progress.finish();
    if !quiet {
        let raw = &decoded.raw;
        let used = raw.header_bytes + raw.base_bytes + raw.stream_bytes;
        note!(
            "{}: {} of {} bytes{}, {} of {} passes -> {}: level {} of {}, {} vertices, {} quads, estimated error {:.3e} ({:.1} dB)",
            input.display(),
            used,
            data.len(),
            if raw.decoded_stream_bytes < raw.stream_bytes {
                let decoded = used - raw.stream_bytes + raw.decoded_stream_bytes;
                match options.max_error {
                    Some(_) => format!(" (the error goal met after the first {decoded})"),
                    None => format!(" (inside a hold: decoded as the first {decoded})"),
                }
            } else {
                String::new()
            },
            raw.passes,
            raw.header.passes,
            output.display(),
            raw.level,
            raw.header.level,
            decoded.mesh.positions.len(),
            decoded.mesh.face_count(),
            decoded.error_estimate(),
            decoded.psnr_estimate(),
        );
    }
    Ok(())
}

fn gltf(
    input: &Path,
    output: Option<PathBuf>,
    options: &qm::gltf::GltfOptions,
    quiet: bool,
) -> Result<(), Failure> {
    let output = output.unwrap_or_else(|| default_output(input, "glb"));
    check_output(input, &output)?;
    let ext = output
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    let json = match ext.as_deref() {
        Some("glb") => false,
        Some("gltf") => true,
        _ => {
            return Err(Failure::parameter(format!(
                "{}: output must be .glb or .gltf",
                output.display()
            )));
        }
    };
    let data = std::fs::read(input).map_err(|e| Failure::about(input, e))?;
    let glb = if json {
        // A .gltf points at the .qm, by default the input beside it.
        let uri = options.uri.clone().unwrap_or_else(|| {
            input
                .file_name()
                .map_or("model.qm".into(), |n| n.to_string_lossy().into_owned())
        });
        qm::gltf::to_gltf(&data, &uri, options)
    } else {
        qm::gltf::to_glb(&data, options)
    }
    .map_err(|e| Failure::about(input, e))?;
    write_atomic(&output, &glb.bytes)?;
    if !quiet {
        note!(
            "{} -> {}: {} bytes; fallback: level {}, {} vertices, {} triangles, from the first {} bytes (estimated {:.1} dB); the .qm {}; {} prefixes in the table",
            input.display(),
            output.display(),
            glb.bytes.len(),
            glb.fallback_level,
            glb.fallback_vertices,
            glb.fallback_triangles,
            glb.fallback_bytes,
            glb.fallback_psnr_db,
            if json {
                "beside it".to_string()
            } else {
                options
                    .uri
                    .as_ref()
                    .map_or("embedded".to_string(), |u| format!("at {u}"))
            },
            glb.levels.len(),
        );
    }
    Ok(())
}
