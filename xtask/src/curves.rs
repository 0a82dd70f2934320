//! What `rd-curve` measures and how a curve is read: one measured
//! reconstruction ([`Point`]), everything measured on one model
//! ([`ModelResult`]), the PSNR targets the coders are compared at
//! ([`TARGETS_DB`]), the bytes a curve needs to reach one ([`bytes_at`],
//! interpolated in log-bytes) and how far a prefix falls below a shorter
//! one ([`largest_fall`]). The runner (`rd`) fills them, the figure
//! (`plot`) draws them.

use qm::param::distance::DistanceReport;

/// PSNR targets at which the coders' sizes are compared.
pub const TARGETS_DB: [f64; 2] = [65.0, 78.0];

/// One measured reconstruction.
#[derive(Clone, Debug)]
pub struct Point {
    pub coder: &'static str,
    pub setting: String,
    pub bytes: usize,
    pub bpv: f64,
    pub report: DistanceReport,
    pub encode_s: f64,
    pub decode_s: f64,
}

/// Everything measured on one model.
#[derive(Clone, Debug)]
pub struct ModelResult {
    pub name: String,
    pub input_bytes: u64,
    pub input_vertices: usize,
    pub input_faces: usize,
    pub prepare_s: f64,
    pub base_quads: usize,
    pub level: u32,
    pub header_base_bytes: usize,
    pub full_bytes: usize,
    /// Table 1: coefficient bytes and PSNR per entry of [`PASSES`].
    pub passes: Vec<(u32, usize, f64)>,
    /// The stream's holds (stream offsets).
    pub holds: Vec<[u32; 2]>,
    pub points: Vec<Point>,
    /// `None` when Draco was not run on this model, with the reason.
    pub draco_missing: Option<String>,
}

impl ModelResult {
    /// PSNR of qm's whole (lossless) stream.
    pub fn lossless_psnr(&self) -> f64 {
        self.points
            .iter()
            .find(|p| p.coder == "qm" && p.setting == "lossless")
            .map_or(f64::NAN, |p| p.report.psnr_db)
    }

    pub fn curve(&self, coder: &str) -> Vec<(usize, f64)> {
        let mut c: Vec<(usize, f64)> = self
            .points
            .iter()
            .filter(|p| p.coder == coder)
            .map(|p| (p.bytes, p.report.psnr_db))
            .collect();
        c.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
        c
    }

    /// The largest fall of qm's PSNR between byte prefixes: how far a
    /// prefix lies below the best shorter one (0 when it never falls). A
    /// pass count decode counts as the prefix that ends with the pass,
    /// unless that end is inside a hold: the prefix then decodes less.
    pub fn largest_fall(&self) -> f64 {
        let held = |bytes: usize| {
            let n = bytes.saturating_sub(self.header_base_bytes);
            qm::codec::container::hold_cut(&self.holds, n) < n
        };
        let mut prefixes: Vec<(usize, f64)> = (self.points.iter())
            .filter(|p| p.coder == "qm" && !(p.setting.starts_with("passes=") && held(p.bytes)))
            .map(|p| (p.bytes, p.report.psnr_db))
            .collect();
        prefixes.sort_by_key(|p| p.0);
        largest_fall(&prefixes)
    }
}

/// The largest amount by which a point of `curve` (sorted by bytes) lies
/// below the best point with fewer bytes.
pub fn largest_fall(curve: &[(usize, f64)]) -> f64 {
    // The best of the points with fewer bytes, and of those with as many.
    let (mut shorter, mut same) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
    let mut fall = 0.0f64;
    for (i, &(bytes, db)) in curve.iter().enumerate() {
        if i > 0 && curve[i - 1].0 < bytes {
            shorter = shorter.max(same);
            same = f64::NEG_INFINITY;
        }
        same = same.max(db);
        fall = fall.max(shorter - db);
    }
    fall
}

/// Bytes a curve needs to reach `target` dB.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AtPsnr {
    /// Interpolated in log-bytes between the two points around the first
    /// crossing.
    Bytes(f64),
    /// The smallest point already reaches the target: at most this many.
    AtMost(f64),
    /// The curve never reaches the target.
    NotReached,
}

impl AtPsnr {
    /// The bytes, exact or at most; `None` when not reached.
    pub(crate) fn value(self) -> Option<f64> {
        match self {
            AtPsnr::Bytes(b) | AtPsnr::AtMost(b) => Some(b),
            AtPsnr::NotReached => None,
        }
    }
}

impl std::fmt::Display for AtPsnr {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            AtPsnr::Bytes(b) => write!(f, "{b:.0}"),
            AtPsnr::AtMost(b) => write!(f, "≤ {b:.0}"),
            AtPsnr::NotReached => f.write_str("n/a"),
        }
    }
}

/// The bytes at which a curve (sorted by bytes) first reaches `target`.
///
/// Only the curve's Pareto front counts: a point that a smaller one matches
/// or beats in PSNR is dropped (Draco at `-qp 7` can be smaller than at
/// `-qp 6`; a qm prefix can be a little worse than a shorter one), so the
/// answer is the fewest bytes known to reach the target.
pub fn bytes_at(curve: &[(usize, f64)], target: f64) -> AtPsnr {
    let mut front: Vec<(usize, f64)> = Vec::new();
    for &(b, p) in curve {
        if front.last().is_none_or(|&(_, best)| p > best) {
            front.push((b, p));
        }
    }
    let curve = &front[..];
    let Some(&(b0, p0)) = curve.first() else {
        return AtPsnr::NotReached;
    };
    if p0 >= target {
        return AtPsnr::AtMost(b0 as f64);
    }
    for w in curve.windows(2) {
        let ((b0, p0), (b1, p1)) = (w[0], w[1]);
        if p0 < target && p1 >= target {
            if !p1.is_finite() {
                return AtPsnr::Bytes(b1 as f64);
            }
            let t = (target - p0) / (p1 - p0);
            let (l0, l1) = ((b0 as f64).ln(), (b1 as f64).ln());
            return AtPsnr::Bytes((l0 + t * (l1 - l0)).exp());
        }
    }
    AtPsnr::NotReached
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_in_log_bytes() {
        let c = [(100, 50.0), (150, 45.0), (400, 70.0), (800, 90.0)];
        let AtPsnr::Bytes(b) = bytes_at(&c, 60.0) else {
            panic!("not reached")
        };
        assert!((b - 200.0).abs() < 1e-9);
        assert_eq!(bytes_at(&c, 95.0), AtPsnr::NotReached);
        assert_eq!(bytes_at(&c, 40.0), AtPsnr::AtMost(100.0));
    }

    #[test]
    fn falls_are_measured_against_shorter_prefixes_only() {
        assert_eq!(largest_fall(&[(10, 50.0), (20, 60.0), (30, 70.0)]), 0.0);
        assert_eq!(largest_fall(&[(10, 50.0), (20, 60.0), (30, 59.5)]), 0.5);
        // Points of equal size are not shorter than each other.
        assert_eq!(largest_fall(&[(10, 50.0), (10, 52.0), (20, 51.0)]), 1.0);
        assert_eq!(largest_fall(&[(10, 52.0), (10, 50.0)]), 0.0);
    }
}
