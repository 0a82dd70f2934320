//! An encoded mesh ([`Compressed`]: the `.qm` bytes, where each pass ends,
//! the samples the stream reproduces) and its cuts measured as a decoder
//! sees them ([`measure_cuts`]): what the encoder's [`crate::holds`] and its
//! choice of frames ([`crate::frames`]) both measure.

use qm_lift::{Coord, Quantizer};
use rayon::prelude::*;

use crate::Result;
use crate::container::Limits;
use crate::decode::Decoder;

/// An encoded mesh and what went into it.
#[derive(Clone, Debug)]
pub struct Compressed {
    /// The `.qm` file contents.
    pub bytes: Vec<u8>,
    /// Bytes of magic, version, header and checksum.
    pub header_bytes: usize,
    /// Bytes of the base section.
    pub base_bytes: usize,
    /// File size at which the first `k + 1` passes end, for each pass. A
    /// file cut there decodes them, unless the cut falls inside a hold
    /// ([`crate::container::Header::hold_cut`]): then it decodes as the hold's
    /// start, which the encoder measured closer to the input.
    pub pass_ends: Vec<usize>,
    /// The quantized samples the stream reproduces exactly when complete.
    pub quantized: Vec<Coord>,
    /// The quantizer used.
    pub quantizer: Quantizer,
}

/// `measure` of the decoded samples of `compressed` at each of the stream
/// cuts `cuts` (ascending), as a decoder sees them (holds and all).
/// Contiguous runs of cuts decode on each thread, each cut resuming from
/// the last one's checkpoint.
pub(crate) fn measure_cuts(
    compressed: &Compressed,
    cuts: &[usize],
    measure: impl Fn(&[Coord]) -> f64 + Sync,
) -> Result<Vec<f64>> {
    // The encoder's own bytes: the decoder's default limits do not apply.
    let decoder = Decoder::new(&compressed.bytes, &Limits::NONE)?;
    let stream = &compressed.bytes[decoder.stream_start()..];
    let run = cuts.len().div_ceil(rayon::current_num_threads()).max(1);
    let runs: Vec<(Decoder, &[usize])> = (cuts.chunks(run))
        .map(|run| (decoder.clone(), run))
        .collect();
    Ok((runs.into_par_iter())
        .flat_map_iter(|(mut decoder, run)| {
            let mut values = Vec::new();
            run.iter()
                .map(|&cut| {
                    decoder.decode_into(&stream[..cut], None, None, &mut values);
                    measure(&values)
                })
                .collect::<Vec<_>>()
        })
        .collect())
}
