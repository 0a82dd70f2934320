//! The sparse system of a disk's parameterization, and its solvers.
//!
//! Main items: [`System`] (the pattern, built once per size, refilled for
//! every solve) and, for large systems, [`MeanValueSystem`] (the
//! row-normalized operator BiCGSTAB iterates on) and [`Preconditioner`].
//! The math is in [`System`]'s docs.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::matrix_free::bicgstab::{BicgParams, bicgstab, bicgstab_scratch};
use faer::matrix_free::{IdentityPrecond, LinOp, Precond};
use faer::sparse::linalg::cholesky::LltRef;
use faer::sparse::linalg::cholesky::{SymmetricOrdering, factorize_symbolic_cholesky};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Mat, MatMut, MatRef, Par, Side};
use qm_lift::glam::DVec2;

use crate::remesh::cut::Disk;
use crate::remesh::lu::{self, SymbolicFactorization};
use crate::{Error, RemeshFailure, Result};

/// Systems with fewer unknowns are solved by a sparse LU (module `lu`);
/// larger ones by BiCGSTAB with a Cholesky preconditioner (see [`System`]).
pub(crate) const LU_BELOW: usize = 100_000;

/// Most BiCGSTAB iterations per solve (see [`System`]).
const REFINEMENTS: usize = 200;

/// Relative residual at which BiCGSTAB stops.
const REFINED: f64 = 1e-8;

/// The symmetric part of `weights`, `(w_ij + w_ji) / 2`: still positive,
/// and with the stretch divisors a positive definite system (see
/// [`System`]). Every triangle adds both directions of its edges, so each
/// entry has its mirror; the sum is commutative, so the two halves come out
/// bit-identical.
pub(super) fn symmetrized(weights: &[Vec<(u32, f64)>]) -> Vec<Vec<(u32, f64)>> {
    let mirror = |i: usize, j: u32| -> f64 {
        weights[j as usize]
            .iter()
            .find(|&&(k, _)| k as usize == i)
            .map_or(0.0, |&(_, x)| x)
    };
    (0..weights.len())
        .map(|i| {
            weights[i]
                .iter()
                .map(|&(j, x)| (j, (x + mirror(i, j)) / 2.0))
                .collect()
        })
        .collect()
}

/// The sparse system of one disk's parameterization: the interior vertices
/// are the unknowns, the boundary vertices fixed.
///
/// Row `i` asks `sum_j a_ij (u_i - u_j) = 0` with `a_ij = w_ij / d_j`: the
/// mean-value weights `w` divided by the far end's accumulated stretch `d`.
/// Scaling row `i` by `1 / d_i` leaves the solution alone and gives
/// `w_ij / (d_i d_j)`, whose symmetric part (`w` symmetrized) is a
/// Dirichlet Laplacian, positive definite.
///
/// Below [`LU_BELOW`] unknowns a sparse LU solves the system directly,
/// without pivoting (the matrix is an M-matrix) on the Cholesky structure
/// of its symmetric pattern (module `lu`). Above, the symmetric part's
/// sparse Cholesky factorization (AMD ordering) preconditions BiCGSTAB on
/// the mean-value system itself, which converges in a few iterations. The
/// symmetric solution alone would not do: without the mean-value weights'
/// linear precision flat parts are sampled unevenly
/// (docs/decisions/013-square-map.md).
///
/// For the Cholesky factorization only the lower triangle is stored. The
/// pattern is built once; every solve refills the values and reuses the
/// disk's symbolic factorization and this system's factor storage and
/// factorization scratch (the BiCGSTAB vectors are allocated per solve).
pub(super) struct System<'a> {
    disk: &'a Disk,
    /// The unknown of each disk vertex (`u32::MAX` for fixed ones).
    index: Vec<u32>,
    /// Column pointers and row indices of the matrix (of its lower triangle
    /// for the Cholesky factorization).
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// Per vertex, where its weight row starts in `slot`.
    row_start: Vec<usize>,
    /// Value position of each weight: `usize::MAX` for fixed neighbours
    /// and for the upper triangle (the mirror entry carries it).
    slot: Vec<usize>,
    /// Value position of each unknown's diagonal.
    diagonal: Vec<usize>,
    values: Vec<f64>,
    /// Small systems: an LU of the mean-value system itself, and its
    /// factors.
    lu: bool,
    numeric: lu::Numeric,
    /// Large ones: the Cholesky factor of its symmetric part, made from
    /// the symmetrized weights.
    factor: Vec<f64>,
    symmetric: Option<Vec<Vec<(u32, f64)>>>,
    scratch: Option<MemBuffer>,
}

impl<'a> System<'a> {
    pub(super) fn new(
        disk: &'a Disk,
        weights: &[Vec<(u32, f64)>],
        fixed: &[bool],
        lu_below: usize,
    ) -> Self {
        let n = disk.positions.len();
        let mut index = vec![u32::MAX; n];
        let mut free = 0u32;
        for v in 0..n {
            if !fixed[v] {
                index[v] = free;
                free += 1;
            }
        }
        let lu = (free as usize) < lu_below;
        // Entries as (column, row, key): key < slot count for a weight,
        // above it for a diagonal. For the Cholesky factorization only the
        // lower triangle, row > column.
        let mut row_start = Vec::with_capacity(n + 1);
        let mut entries = Vec::new();
        let mut keys = 0usize;
        for v in 0..n {
            row_start.push(keys);
            for &(j, _) in &weights[v] {
                let (r, c) = (index[v], index[j as usize]);
                if r != u32::MAX && c != u32::MAX && (r > c || lu) {
                    entries.push((c as usize, r as usize, keys));
                }
                keys += 1;
            }
        }
        row_start.push(keys);
        for r in 0..free as usize {
            entries.push((r, r, keys + r));
        }
        entries.sort_unstable();
        let free = free as usize;
        let mut col_ptr = vec![0usize; free + 1];
        let mut row_idx = Vec::with_capacity(entries.len());
        let mut slot = vec![usize::MAX; keys];
        let mut diagonal = vec![0usize; free];
        for (position, &(col, row, key)) in entries.iter().enumerate() {
            col_ptr[col + 1] += 1;
            row_idx.push(row);
            if key < keys {
                slot[key] = position;
            } else {
                diagonal[key - keys] = position;
            }
        }
        for c in 0..free {
            col_ptr[c + 1] += col_ptr[c];
        }
        System {
            disk,
            index,
            values: vec![0.0; row_idx.len()],
            col_ptr,
            row_idx,
            row_start,
            slot,
            diagonal,
            lu,
            numeric: Default::default(),
            factor: Vec::new(),
            symmetric: (!lu).then(|| symmetrized(weights)),
            scratch: None,
        }
    }

    /// Solves for the free vertices' `uv` given the fixed ones: the system
    /// of the mean-value `weights` divided by `divisor` at the far end.
    pub(super) fn solve(
        &mut self,
        weights: &[Vec<(u32, f64)>],
        divisor: &[f64],
        uv: &mut [DVec2],
    ) -> Result<()> {
        let free = self.diagonal.len();
        if free == 0 {
            return Ok(());
        }
        if self.lu {
            self.solve_lu(weights, divisor, uv)
        } else {
            self.solve_cholesky(weights, divisor, uv)
        }
    }

    /// Fills the matrix entries (those the pattern holds) from `weights`,
    /// each divided by `divisor(i, j)`, and returns the right-hand side,
    /// the fixed neighbours' pull.
    fn fill(
        &mut self,
        weights: &[Vec<(u32, f64)>],
        divisor: impl Fn(usize, usize) -> f64,
        uv: &[DVec2],
    ) -> Mat<f64> {
        let mut rhs = Mat::<f64>::zeros(self.diagonal.len(), 2);
        for (v, row) in weights.iter().enumerate() {
            let r = self.index[v];
            if r == u32::MAX {
                continue;
            }
            let r = r as usize;
            let mut diagonal = 0.0;
            for (key, &(j, w)) in (self.row_start[v]..).zip(row) {
                // Positive: `mean_value_weights` floors the weights, the
                // divisors are stretches (floored too).
                let a = w / divisor(v, j as usize);
                diagonal += a;
                if self.index[j as usize] == u32::MAX {
                    rhs[(r, 0)] += a * uv[j as usize].x;
                    rhs[(r, 1)] += a * uv[j as usize].y;
                } else if self.slot[key] != usize::MAX {
                    self.values[self.slot[key]] = -a;
                }
            }
            self.values[self.diagonal[r]] = diagonal;
        }
        rhs
    }

    /// The disk's symbolic factorization, made by `make` on first use.
    fn symbolic<E: std::fmt::Debug>(
        &self,
        pattern: SymbolicSparseColMatRef<'_, usize>,
        make: impl FnOnce(
            SymbolicSparseColMatRef<'_, usize>,
        ) -> std::result::Result<SymbolicFactorization, E>,
    ) -> Result<&'a SymbolicFactorization> {
        self.disk
            .symbolic
            .get_or_init(|| make(pattern).map_err(|e| format!("{e:?}")))
            .as_ref()
            .map_err(|e| {
                Error::remesh(RemeshFailure::Step(format!(
                    "factoring the parameterization: {e}"
                )))
            })
    }

    /// A direct LU solve of the mean-value system, row `i` as it is:
    /// `a_ij = w_ij / d_j`.
    fn solve_lu(
        &mut self,
        weights: &[Vec<(u32, f64)>],
        divisor: &[f64],
        uv: &mut [DVec2],
    ) -> Result<()> {
        let free = self.diagonal.len();
        let mut rhs = self.fill(weights, |_, j| divisor[j], uv);
        let pattern =
            SymbolicSparseColMatRef::new_checked(free, free, &self.col_ptr, None, &self.row_idx);
        let symbolic = self.symbolic(pattern, |p| {
            lu::Symbolic::new(p).map(SymbolicFactorization::Lu)
        })?;
        let SymbolicFactorization::Lu(symbolic) = symbolic else {
            unreachable!("a disk's systems all have its size")
        };
        symbolic
            .factorize(&self.values, &mut self.numeric)
            .map_err(|i| {
                Error::remesh(RemeshFailure::Step(format!(
                    "factoring the parameterization: pivot {i}"
                )))
            })?;
        symbolic.solve(&self.numeric, rhs.as_mut());
        write_back(&self.index, &rhs, uv);
        Ok(())
    }

    /// The mean-value system by BiCGSTAB, preconditioned by the Cholesky
    /// factorization of its row-scaled symmetric part, from that part's
    /// own solution.
    fn solve_cholesky(
        &mut self,
        weights: &[Vec<(u32, f64)>],
        divisor: &[f64],
        uv: &mut [DVec2],
    ) -> Result<()> {
        let free = self.diagonal.len();
        let symmetric = self.symmetric.take().expect("made for this path");
        self.fill(&symmetric, |v, j| divisor[v] * divisor[j], uv);
        self.symmetric = Some(symmetric);
        let pattern =
            SymbolicSparseColMatRef::new_checked(free, free, &self.col_ptr, None, &self.row_idx);
        let matrix = SparseColMatRef::new(pattern, &self.values);
        let symbolic = self.symbolic(pattern, |p| {
            factorize_symbolic_cholesky(p, Side::Lower, SymmetricOrdering::Amd, Default::default())
                .map(SymbolicFactorization::Cholesky)
        })?;
        let SymbolicFactorization::Cholesky(symbolic) = symbolic else {
            unreachable!("a disk's systems all have its size")
        };
        let scratch = self.scratch.get_or_insert_with(|| {
            MemBuffer::new(StackReq::any_of(&[
                symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
                symbolic.solve_in_place_scratch::<f64>(2, Par::Seq),
            ]))
        });
        self.factor.resize(symbolic.len_val(), 0.0);
        let llt = symbolic
            .factorize_numeric_llt(
                &mut self.factor,
                matrix,
                Side::Lower,
                LltRegularization::default(),
                Par::Seq,
                MemStack::new(scratch),
                Default::default(),
            )
            .map_err(|e| {
                Error::remesh(RemeshFailure::Step(format!(
                    "factoring the parameterization: {e:?}"
                )))
            })?;
        let (operator, b) = MeanValueSystem::new(weights, divisor, &self.index, uv, free);
        let preconditioner = Preconditioner {
            llt,
            row_sums: &operator.diagonal,
        };
        let mut x = b.clone();
        preconditioner.apply_in_place(x.as_mut(), Par::Seq, MemStack::new(scratch));
        let symmetric_solution = x.clone();
        let identity = IdentityPrecond { dim: free };
        let mut memory = MemBuffer::new(bicgstab_scratch(
            identity,
            &preconditioner,
            &operator,
            2,
            Par::Seq,
        ));
        let params = BicgParams {
            rel_tolerance: REFINED,
            max_iters: REFINEMENTS,
            ..Default::default()
        };
        let solved = bicgstab(
            x.as_mut(),
            identity,
            &preconditioner,
            &operator,
            b.as_ref(),
            params,
            |_| {},
            Par::Seq,
            MemStack::new(&mut memory),
        );
        // Should it not converge, the better of its last iterate and the
        // symmetric solution stays.
        let x = if solved.is_ok()
            || operator.residual(&x, &b) < operator.residual(&symmetric_solution, &b)
        {
            x
        } else {
            symmetric_solution
        };
        write_back(&self.index, &x, uv);
        Ok(())
    }
}

/// Copies the unknowns `x` into the free vertices' `uv`.
fn write_back(index: &[u32], x: &Mat<f64>, uv: &mut [DVec2]) {
    for (v, p) in uv.iter_mut().enumerate() {
        let r = index[v];
        if r != u32::MAX {
            *p = DVec2::new(x[(r as usize, 0)], x[(r as usize, 1)]);
        }
    }
}

/// The free block of the mean-value system with each row divided by its
/// diagonal, `(A x)_i = x_i - sum_j p_ij x_j` over free neighbours `j`,
/// `p_ij = a_ij / sum_k a_ik` with `a_ij = w_ij / (d_i d_j)`, in compact
/// rows. Every row is then a weighted mean, in parameter units, so a small
/// relative residual means every vertex is close, however unevenly the
/// reweighting scaled the rows.
#[derive(Debug)]
struct MeanValueSystem {
    /// Per unknown, where its entries start in `column` and `value`.
    start: Vec<usize>,
    column: Vec<u32>,
    value: Vec<f64>,
    /// Per unknown, the row's sum `sum_k a_ik` it was divided by.
    diagonal: Vec<f64>,
}

impl MeanValueSystem {
    /// The system of `weights` divided by `divisor` at both ends, for the
    /// unknowns `index`, and its right-hand side: the fixed neighbours'
    /// pull `b_i = sum a_ij uv_j`.
    fn new(
        weights: &[Vec<(u32, f64)>],
        divisor: &[f64],
        index: &[u32],
        uv: &[DVec2],
        free: usize,
    ) -> (Self, Mat<f64>) {
        let mut system = MeanValueSystem {
            start: Vec::with_capacity(free + 1),
            column: Vec::new(),
            value: Vec::new(),
            diagonal: Vec::with_capacity(free),
        };
        let mut b = Mat::<f64>::zeros(free, 2);
        for (v, row) in weights.iter().enumerate() {
            let r = index[v];
            if r == u32::MAX {
                continue;
            }
            system.start.push(system.column.len());
            let mut diagonal = 0.0;
            for &(j, w) in row {
                let a = w / (divisor[v] * divisor[j as usize]);
                diagonal += a;
                match index[j as usize] {
                    u32::MAX => {
                        b[(r as usize, 0)] += a * uv[j as usize].x;
                        b[(r as usize, 1)] += a * uv[j as usize].y;
                    }
                    c => {
                        system.column.push(c);
                        system.value.push(a);
                    }
                }
            }
            system.diagonal.push(diagonal);
            for a in &mut system.value[*system.start.last().expect("pushed")..] {
                *a /= diagonal;
            }
            b[(r as usize, 0)] /= diagonal;
            b[(r as usize, 1)] /= diagonal;
        }
        system.start.push(system.column.len());
        (system, b)
    }

    /// `|b - A x|`.
    fn residual(&self, x: &Mat<f64>, b: &Mat<f64>) -> f64 {
        let mut ax = Mat::<f64>::zeros(self.diagonal.len(), 2);
        self.apply(ax.as_mut(), x.as_ref(), Par::Seq, MemStack::new(&mut []));
        (b - &ax).norm_l2()
    }
}

impl LinOp<f64> for MeanValueSystem {
    fn apply_scratch(&self, _rhs_ncols: usize, _par: Par) -> StackReq {
        StackReq::EMPTY
    }

    fn nrows(&self) -> usize {
        self.diagonal.len()
    }

    fn ncols(&self) -> usize {
        self.diagonal.len()
    }

    fn apply(&self, mut out: MatMut<'_, f64>, rhs: MatRef<'_, f64>, _: Par, _: &mut MemStack) {
        for k in 0..rhs.ncols() {
            let x = rhs.col(k);
            let mut y = out.as_mut().col_mut(k);
            for r in 0..self.diagonal.len() {
                let entries = self.start[r]..self.start[r + 1];
                let mut sum = x[r];
                for (&c, &a) in self.column[entries.clone()]
                    .iter()
                    .zip(&self.value[entries])
                {
                    sum -= a * x[c as usize];
                }
                y[r] = sum;
            }
        }
    }

    fn conj_apply(
        &self,
        out: MatMut<'_, f64>,
        rhs: MatRef<'_, f64>,
        par: Par,
        stack: &mut MemStack,
    ) {
        self.apply(out, rhs, par, stack);
    }
}

/// The symmetric part's Cholesky factorization as a preconditioner of the
/// row-normalized system: `M^-1 diag(row sums) r`.
#[derive(Debug)]
struct Preconditioner<'a> {
    llt: LltRef<'a, usize, f64>,
    row_sums: &'a [f64],
}

impl LinOp<f64> for Preconditioner<'_> {
    fn apply_scratch(&self, rhs_ncols: usize, par: Par) -> StackReq {
        self.llt
            .symbolic()
            .solve_in_place_scratch::<f64>(rhs_ncols, par)
    }

    fn nrows(&self) -> usize {
        self.row_sums.len()
    }

    fn ncols(&self) -> usize {
        self.row_sums.len()
    }

    fn apply(
        &self,
        mut out: MatMut<'_, f64>,
        rhs: MatRef<'_, f64>,
        par: Par,
        stack: &mut MemStack,
    ) {
        out.copy_from(rhs);
        self.apply_in_place(out, par, stack);
    }

    fn conj_apply(
        &self,
        out: MatMut<'_, f64>,
        rhs: MatRef<'_, f64>,
        par: Par,
        stack: &mut MemStack,
    ) {
        self.apply(out, rhs, par, stack);
    }
}

impl Precond<f64> for Preconditioner<'_> {
    fn apply_in_place_scratch(&self, rhs_ncols: usize, par: Par) -> StackReq {
        self.apply_scratch(rhs_ncols, par)
    }

    fn apply_in_place(&self, mut rhs: MatMut<'_, f64>, par: Par, stack: &mut MemStack) {
        for k in 0..rhs.ncols() {
            for (r, &d) in self.row_sums.iter().enumerate() {
                rhs[(r, k)] *= d;
            }
        }
        self.llt.solve_in_place_with_conj(Conj::No, rhs, par, stack);
    }

    fn conj_apply_in_place(&self, rhs: MatMut<'_, f64>, par: Par, stack: &mut MemStack) {
        self.apply_in_place(rhs, par, stack);
    }
}
