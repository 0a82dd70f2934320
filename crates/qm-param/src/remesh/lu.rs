//! A sparse LU factorization without pivoting, for the parameterization's
//! mean-value systems below [`super::square`]'s `LU_BELOW` unknowns.
//!
//! Those matrices have a symmetric pattern (a weight each way along every
//! mesh edge) and are M-matrices: positive diagonal, negative weights, each
//! row's diagonal at least the sum of its weights. Gaussian elimination
//! keeps that in every Schur complement, so it needs no pivoting (its
//! pivots stay positive and its growth bounded), and the factors have the
//! pattern of the Cholesky factor of the pattern: `L` that of the Cholesky
//! factor, `U` its transpose. The factorization runs on faer's supernodal
//! Cholesky structure (AMD ordering), left-looking as faer's own Cholesky
//! does, with dense blocks.
//!
//! Left-looking, a supernode reads only its descendants in the elimination
//! tree, and where the ordering is a postorder a subtree is a range of
//! supernodes (AMD's often is not, in places): such whole subtrees below
//! the top separators are factored in two halves at once (see [`split`]),
//! then the rest; the two columns of the right-hand side are solved at
//! once. Every supernode does the same arithmetic in the same order as on
//! one thread, so the factors and solutions are the same bit for bit; a
//! failed pivot sends the factorization back to one thread from the start,
//! so that it is reported where one thread meets it first.
//!
//! On the bunny (in-process timings of the 13 solves of a remesh, 4 runs
//! of each build interleaved, machine not idle) the median factorization
//! took 35.4 ms instead of 39.6 ms (about a third of the work is in the
//! top separators, which stay on one thread) and the median solve 8.5 ms
//! instead of 14.0.
//!
//! faer's general sparse LU (partial pivoting, COLAMD ordering) has to
//! allow for any row exchange, so its factors follow the pattern of
//! `A^T A`. On the bunny's 34,496 unknowns, the same matrices back to back
//! on one thread (with other jobs on the machine, load about 5): faer took
//! 0.10 to 0.13 s per factorization and 0.06 s for the structure, this
//! 0.035 to 0.046 s and 0.035 s; the solutions agreed to 4e-14 (of values
//! up to 1). Without normal placement, spot's and cheburashka's remeshes
//! moved by at most 4e-14 of their bounding box diagonal.

use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_unit_lower_triangular_in_place,
};
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::sparse::SymbolicSparseColMatRef;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholeskyRaw, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::{Accum, MatMut, MatRef, Par, Side};
use rayon::prelude::*;

/// The structure of the factors of a matrix of symmetric pattern.
pub struct Symbolic {
    /// `forward[i]` is the unknown in position `i` of the ordering.
    forward: Vec<usize>,
    /// Supernode `s` is the columns `begin[s]..begin[s + 1]` (ordered).
    begin: Vec<usize>,
    /// Its rows below the diagonal block: `rows[pattern[s]..pattern[s + 1]]`.
    pattern: Vec<usize>,
    rows: Vec<usize>,
    /// Its values: `values[s]..values[s + 1]` of `L`, column-major, the
    /// diagonal block then the rows below; the same of `U^T` (whose
    /// diagonal block is unused: `L`'s holds both factors of it).
    values: Vec<usize>,
    /// The supernodes whose rows reach into supernode `s`'s columns:
    /// `below[updates[s]..updates[s + 1]]`.
    updates: Vec<usize>,
    below: Vec<usize>,
    /// Per stored entry of the matrix, where its value goes: `L`'s values
    /// below `values[last]`, `U^T`'s above.
    dest: Vec<usize>,
    /// Whole subtrees of the supernodes' elimination tree (ranges of
    /// supernodes, in ascending order) and the half of two that factors
    /// each; the supernodes outside them come after, in order.
    split: Vec<(std::ops::Range<usize>, usize)>,
}

/// A range of supernodes that is a whole subtree, with its stretch of `L`'s
/// and `U^T`'s values.
type Subtree<'a> = (std::ops::Range<usize>, &'a mut [f64], &'a mut [f64]);

/// The numeric factors.
#[derive(Default)]
pub struct Numeric {
    l: Vec<f64>,
    u: Vec<f64>,
    /// Per half of [`Symbolic::split`] (the first also for the rest): the
    /// rows' places in the supernode at hand (`usize::MAX` between
    /// supernodes), and room for the dense products.
    local: [Vec<usize>; 2],
    scratch: [Vec<f64>; 2],
}

impl Symbolic {
    /// The structure for the square matrix of pattern `matrix` (every
    /// column's diagonal included), which must be symmetric.
    pub fn new(matrix: SymbolicSparseColMatRef<'_, usize>) -> Result<Symbolic, String> {
        let n = matrix.ncols();
        // The lower triangle, for the Cholesky structure.
        let mut col_ptr = vec![0usize; n + 1];
        let mut row_idx = Vec::new();
        for j in 0..n {
            row_idx.extend(matrix.row_idx_of_col(j).filter(|&i| i >= j));
            col_ptr[j + 1] = row_idx.len();
        }
        let lower = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let cholesky = factorize_symbolic_cholesky(
            lower,
            Side::Lower,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                ..Default::default()
            },
        )
        .map_err(|e| format!("{e:?}"))?;
        let (forward, inverse): (Vec<usize>, Vec<usize>) = match cholesky.perm() {
            Some(perm) => {
                let (f, i) = perm.arrays();
                (f.to_vec(), i.to_vec())
            }
            None => ((0..n).collect(), (0..n).collect()),
        };
        let mut begin = Vec::new();
        let mut pattern = vec![0usize];
        let mut rows = Vec::new();
        let mut values = vec![0usize];
        match cholesky.raw() {
            SymbolicCholeskyRaw::Supernodal(supernodal) => {
                begin.extend_from_slice(supernodal.supernode_begin());
                for s in 0..supernodal.n_supernodes() {
                    rows.extend_from_slice(supernodal.supernode(s).pattern());
                    pattern.push(rows.len());
                }
                values = supernodal.col_ptr_for_val()[..=supernodal.n_supernodes()].to_vec();
            }
            // (Tiny matrices.) Each column a supernode.
            SymbolicCholeskyRaw::Simplicial(simplicial) => {
                let factor = simplicial.factor();
                for j in 0..n {
                    begin.push(j);
                    rows.extend(factor.row_idx_of_col(j).filter(|&i| i > j));
                    pattern.push(rows.len());
                    values.push(values[j] + 1 + pattern[j + 1] - pattern[j]);
                }
            }
        }
        begin.push(n);
        let supernodes = begin.len() - 1;
        let mut owner = vec![0usize; n];
        for s in 0..supernodes {
            owner[begin[s]..begin[s + 1]].fill(s);
        }
        // Supernode `d` updates every supernode its rows fall in.
        let mut reached: Vec<Vec<usize>> = vec![Vec::new(); supernodes];
        for d in 0..supernodes {
            let mut last = usize::MAX;
            for &r in &rows[pattern[d]..pattern[d + 1]] {
                if owner[r] != last {
                    last = owner[r];
                    reached[last].push(d);
                }
            }
        }
        let split = split(&rows, &pattern, &owner, &begin);
        let mut updates = vec![0usize];
        let mut below = Vec::new();
        for r in &reached {
            below.extend_from_slice(r);
            updates.push(below.len());
        }
        let total = values[supernodes];
        let mut dest = Vec::with_capacity(matrix.row_idx().len());
        for j in 0..n {
            for r in matrix.row_idx_of_col(j) {
                let (i, k) = (inverse[r], inverse[j]);
                let (lo, hi) = (i.min(k), i.max(k));
                let s = owner[lo];
                let (b, e) = (begin[s], begin[s + 1]);
                let height = e - b + pattern[s + 1] - pattern[s];
                let local = if hi < e {
                    hi - b
                } else {
                    let at = rows[pattern[s]..pattern[s + 1]]
                        .binary_search(&hi)
                        .map_err(|_| "an entry outside the factors' pattern".to_string())?;
                    e - b + at
                };
                dest.push(if hi < e {
                    // The diagonal block, both triangles, in `L`.
                    values[s] + (i - b) + (k - b) * height
                } else if i > k {
                    values[s] + local + (k - b) * height
                } else {
                    total + values[s] + local + (i - b) * height
                });
            }
        }
        Ok(Symbolic {
            forward,
            begin,
            pattern,
            rows,
            values,
            updates,
            below,
            dest,
            split,
        })
    }

    fn supernodes(&self) -> usize {
        self.begin.len() - 1
    }

    fn rows_of(&self, s: usize) -> &[usize] {
        &self.rows[self.pattern[s]..self.pattern[s + 1]]
    }

    /// Factors the matrix of the pattern given to [`Symbolic::new`] with
    /// `values` (in its order); `Err(i)` at a pivot that is not positive
    /// and finite, in ordered position `i`.
    pub fn factorize(&self, values: &[f64], numeric: &mut Numeric) -> Result<(), usize> {
        self.scatter(values, numeric);
        if !self.split.is_empty() && self.factor_split(numeric).is_err() {
            // Where a pivot fails, the position one thread meets first:
            // from the start, on one thread (a separator before the failed
            // subtree may fail too).
            self.scatter(values, numeric);
            return self.factor_rest(numeric, &[]);
        }
        self.factor_rest(numeric, &self.split)
    }

    /// Puts the matrix `values` in the factors' storage, and readies the
    /// row places.
    fn scatter(&self, values: &[f64], numeric: &mut Numeric) {
        let total = self.values[self.supernodes()];
        let (l, u) = (&mut numeric.l, &mut numeric.u);
        l.clear();
        l.resize(total, 0.0);
        u.clear();
        u.resize(total, 0.0);
        for (&d, &v) in self.dest.iter().zip(values) {
            if d < total {
                l[d] += v;
            } else {
                u[d - total] += v;
            }
        }
        for local in &mut numeric.local {
            local.clear();
            local.resize(self.forward.len(), usize::MAX);
        }
    }

    /// Factors the [`Symbolic::split`] subtrees, each half on a thread of
    /// its own with its own stretch of the factors.
    fn factor_split(&self, numeric: &mut Numeric) -> Result<(), usize> {
        let mut parts: [Vec<Subtree<'_>>; 2] = Default::default();
        let (mut l_rest, mut u_rest, mut at) = (&mut numeric.l[..], &mut numeric.u[..], 0);
        for (range, half) in &self.split {
            let (first, last) = (self.values[range.start], self.values[range.end]);
            let (l_part, l_after) = l_rest[first - at..].split_at_mut(last - first);
            let (u_part, u_after) = u_rest[first - at..].split_at_mut(last - first);
            parts[*half].push((range.clone(), l_part, u_part));
            (l_rest, u_rest, at) = (l_after, u_after, last);
        }
        let [first, second] = parts;
        let ([local_a, local_b], [scratch_a, scratch_b]) =
            (&mut numeric.local, &mut numeric.scratch);
        let (a, b) = rayon::join(
            || self.factor_subtrees(first, local_a, scratch_a),
            || self.factor_subtrees(second, local_b, scratch_b),
        );
        a.and(b)
    }

    /// Factors whole subtrees, each in its own stretch of the factors.
    fn factor_subtrees(
        &self,
        subtrees: Vec<Subtree<'_>>,
        local: &mut [usize],
        scratch: &mut Vec<f64>,
    ) -> Result<(), usize> {
        subtrees.into_iter().try_for_each(|(range, l, u)| {
            let base = self.values[range.start];
            range
                .into_iter()
                .try_for_each(|s| self.supernode(s, l, u, base, local, scratch))
        })
    }

    /// Factors, in order and on this thread, every supernode outside the
    /// ranges of `done` (ascending, already factored).
    fn factor_rest(
        &self,
        numeric: &mut Numeric,
        done: &[(std::ops::Range<usize>, usize)],
    ) -> Result<(), usize> {
        let mut done = done.iter().map(|(range, _)| range).peekable();
        let mut s = 0;
        while s < self.supernodes() {
            if let Some(range) = done.next_if(|range| range.start == s) {
                s = range.end;
                continue;
            }
            self.supernode(
                s,
                &mut numeric.l,
                &mut numeric.u,
                0,
                &mut numeric.local[0],
                &mut numeric.scratch[0],
            )?;
            s += 1;
        }
        Ok(())
    }

    /// Factors supernode `s` (left-looking: its descendants are done), in
    /// `l` and `u` that start at value `base` and hold it and every
    /// descendant. `local` is all `usize::MAX`, and left so unless a pivot
    /// fails.
    fn supernode(
        &self,
        s: usize,
        l: &mut [f64],
        u: &mut [f64],
        base: usize,
        local: &mut [usize],
        scratch: &mut Vec<f64>,
    ) -> Result<(), usize> {
        let (b, e) = (self.begin[s], self.begin[s + 1]);
        let width = e - b;
        let rows = self.rows_of(s);
        let height = width + rows.len();
        for (i, &r) in rows.iter().enumerate() {
            local[r] = width + i;
        }
        let (l_done, l_rest) = l.split_at_mut(self.values[s] - base);
        let (u_done, u_rest) = u.split_at_mut(self.values[s] - base);
        let size = self.values[s + 1] - self.values[s];
        let (ls, us) = (&mut l_rest[..size], &mut u_rest[..size]);
        for &d in &self.below[self.updates[s]..self.updates[s + 1]] {
            let d_width = self.begin[d + 1] - self.begin[d];
            let d_rows = self.rows_of(d);
            let d_height = d_width + d_rows.len();
            let span = self.values[d] - base..self.values[d + 1] - base;
            let ld = MatRef::from_column_major_slice(&l_done[span.clone()], d_height, d_width);
            let ud = MatRef::from_column_major_slice(&u_done[span], d_height, d_width);
            // d's rows from s's columns on: `mid` in them, then below.
            let first = d_rows.partition_point(|&r| r < b);
            let mid = d_rows[first..].partition_point(|&r| r < e);
            let reach = &d_rows[first..];
            let ld = ld.subrows(d_width + first, reach.len());
            let ud = ud.subrows(d_width + first, reach.len());
            // L (and the diagonal block): rows from b on, columns mid.
            let update = product(scratch, ld, ud.subrows(0, mid));
            for (c, &col) in reach[..mid].iter().enumerate() {
                let column = &mut ls[(col - b) * height..][..height];
                for (&row, &x) in reach.iter().zip(&update[c * reach.len()..]) {
                    column[if row < e { row - b } else { local[row] }] -= x;
                }
            }
            // U: rows mid, columns below (as U^T).
            let below = &reach[mid..];
            let update = product(scratch, ud.subrows(mid, below.len()), ld.subrows(0, mid));
            for (c, &col) in reach[..mid].iter().enumerate() {
                let column = &mut us[(col - b) * height..][..height];
                for (&row, &x) in below.iter().zip(&update[c * below.len()..]) {
                    column[local[row]] -= x;
                }
            }
        }
        let mut ls = MatMut::from_column_major_slice_mut(ls, height, width);
        let (mut top, mut bottom) = ls.rb_mut().split_at_row_mut(width);
        dense_lu(top.rb_mut()).map_err(|i| b + i)?;
        // L below: A21 U11^-1; U right (as U^T): (L11^-1 A12)^T.
        let mut us = MatMut::from_column_major_slice_mut(us, height, width);
        let (_, mut us_bottom) = us.rb_mut().split_at_row_mut(width);
        if width <= SMALL {
            for j in 0..width {
                for k in 0..j {
                    let (upper, lower) = (top[(k, j)], top[(j, k)]);
                    for i in 0..rows.len() {
                        let x = bottom[(i, k)];
                        bottom[(i, j)] -= x * upper;
                        let y = us_bottom[(i, k)];
                        us_bottom[(i, j)] -= y * lower;
                    }
                }
                let pivot = top[(j, j)];
                for i in 0..rows.len() {
                    bottom[(i, j)] /= pivot;
                }
            }
        } else {
            solve_lower_triangular_in_place(top.rb().transpose(), bottom.transpose_mut(), Par::Seq);
            solve_unit_lower_triangular_in_place(top.rb(), us_bottom.transpose_mut(), Par::Seq);
        }
        for &r in rows {
            local[r] = usize::MAX;
        }
        Ok(())
    }

    /// Solves `A x = rhs` in place, with `A` factored in `numeric`.
    pub fn solve(&self, numeric: &Numeric, mut rhs: MatMut<'_, f64>) {
        // Each column in the factors' order, the columns in parallel.
        let mut columns: Vec<Vec<f64>> = (0..rhs.ncols())
            .map(|c| self.forward.iter().map(|&f| rhs[(f, c)]).collect())
            .collect();
        columns
            .par_iter_mut()
            .for_each(|x| self.solve_column(numeric, x));
        for (c, x) in columns.iter().enumerate() {
            for (&f, &x) in self.forward.iter().zip(x) {
                rhs[(f, c)] = x;
            }
        }
    }

    /// [`Symbolic::solve`] for one column `x`, in the factors' order.
    fn solve_column(&self, numeric: &Numeric, x: &mut [f64]) {
        // L y = P rhs, supernode by supernode.
        for s in 0..self.supernodes() {
            let (b, width) = (self.begin[s], self.begin[s + 1] - self.begin[s]);
            let rows = self.rows_of(s);
            let height = width + rows.len();
            let ls = &numeric.l[self.values[s]..self.values[s + 1]];
            for j in 0..width {
                let xj = x[b + j];
                let column = &ls[j * height..][..height];
                let below = (b + j + 1..b + width).zip(&column[j + 1..width]);
                for (r, &v) in below.chain(rows.iter().copied().zip(&column[width..])) {
                    x[r] -= v * xj;
                }
            }
        }
        // U z = y, backwards.
        for s in (0..self.supernodes()).rev() {
            let (b, width) = (self.begin[s], self.begin[s + 1] - self.begin[s]);
            let rows = self.rows_of(s);
            let height = width + rows.len();
            let ls = &numeric.l[self.values[s]..self.values[s + 1]];
            let us = &numeric.u[self.values[s]..self.values[s + 1]];
            for j in (0..width).rev() {
                let mut xj = x[b + j];
                let right = (b + j + 1..b + width).map(|c| (c, ls[(c - b) * height + j]));
                let beyond = rows
                    .iter()
                    .copied()
                    .zip(us[j * height + width..][..rows.len()].iter().copied());
                for (r, v) in right.chain(beyond) {
                    xj -= v * x[r];
                }
                x[b + j] = xj / ls[j * height + j];
            }
        }
    }
}

/// Disjoint subtrees of the supernodes' elimination tree to factor in two
/// halves at once, as ranges (in ascending order) with their half: from the
/// roots down, the subtree with the most work is replaced by its children
/// while it holds more than half of the work left in subtrees, and the
/// subtrees then go, largest first, to the half with less work. Work is
/// counted as `width height^2` per supernode. Only subtrees that are one
/// range of supernodes are taken (where the ordering is a postorder
/// there); none when there are too few supernodes to be worth it.
fn split(
    rows: &[usize],
    pattern: &[usize],
    owner: &[usize],
    begin: &[usize],
) -> Vec<(std::ops::Range<usize>, usize)> {
    let supernodes = begin.len() - 1;
    if supernodes < 16 {
        return Vec::new();
    }
    // The parent is the supernode of the first row below (rows ascend).
    let parent: Vec<Option<usize>> = (0..supernodes)
        .map(|s| rows[pattern[s]..pattern[s + 1]].first().map(|&r| owner[r]))
        .collect();
    let (mut work, mut size) = (vec![0.0f64; supernodes], vec![1usize; supernodes]);
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); supernodes];
    for s in 0..supernodes {
        let height = (begin[s + 1] - begin[s] + pattern[s + 1] - pattern[s]) as f64;
        work[s] += (begin[s + 1] - begin[s]) as f64 * height * height;
        if let Some(p) = parent[s] {
            if p <= s {
                return Vec::new();
            }
            work[p] += work[s];
            size[p] += size[s];
            children[p].push(s);
        }
    }
    // Subtree `s` is the range `first(s)..=s` (`whole[s]`) if its children's
    // subtrees are, and lie in that range: then they tile it, their sizes
    // adding up to its length. AMD's ordering is often not a postorder.
    let first = |s: usize| s + 1 - size[s];
    let mut whole = vec![true; supernodes];
    for s in 0..supernodes {
        if let Some(p) = parent[s] {
            whole[p] &= whole[s] && first(s) >= first(p);
        }
    }
    let mut frontier: Vec<usize> = (0..supernodes).filter(|&s| parent[s].is_none()).collect();
    loop {
        // A subtree that is not one range is replaced by its children (it
        // has some: a leaf is one range), so the frontier is never empty.
        if let Some(at) = frontier.iter().position(|&s| !whole[s]) {
            let s = frontier.swap_remove(at);
            frontier.extend_from_slice(&children[s]);
            continue;
        }
        let total: f64 = frontier.iter().map(|&s| work[s]).sum();
        let (at, &largest) = frontier
            .iter()
            .enumerate()
            .max_by(|a, b| work[*a.1].total_cmp(&work[*b.1]))
            .expect("a tree has a root");
        if 2.0 * work[largest] <= total || children[largest].is_empty() {
            break;
        }
        frontier.swap_remove(at);
        frontier.extend_from_slice(&children[largest]);
    }
    frontier.sort_by(|&a, &b| work[b].total_cmp(&work[a]));
    let mut load = [0.0f64; 2];
    let mut split: Vec<(std::ops::Range<usize>, usize)> = frontier
        .into_iter()
        .map(|s| {
            let half = usize::from(load[1] < load[0]);
            load[half] += work[s];
            (first(s)..s + 1, half)
        })
        .collect();
    split.sort_by_key(|(range, _)| range.start);
    split
}

/// Widest supernode whose triangular solves run as plain loops.
const SMALL: usize = 16;

/// `a b^T` (column-major, `a.nrows() x b.nrows()`) in the front of
/// `buffer`: plain loops for small products, faer's otherwise.
fn product<'a>(buffer: &'a mut Vec<f64>, a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> &'a [f64] {
    let (rows, cols, inner) = (a.nrows(), b.nrows(), a.ncols());
    if buffer.len() < rows * cols {
        buffer.resize(rows * cols, 0.0);
    }
    let out = &mut buffer[..rows * cols];
    if rows * cols * inner <= 4096 {
        out.fill(0.0);
        for c in 0..cols {
            let column = &mut out[c * rows..][..rows];
            for k in 0..inner {
                let y = b[(c, k)];
                for (i, o) in column.iter_mut().enumerate() {
                    *o += a[(i, k)] * y;
                }
            }
        }
    } else {
        let out_mat = MatMut::from_column_major_slice_mut(&mut *out, rows, cols);
        matmul(out_mat, Accum::Replace, a, b.transpose(), 1.0, Par::Seq);
    }
    &buffer[..rows * cols]
}

/// Dense LU without pivoting in place (unit `L` below the diagonal, `U` on
/// and above); `Err(i)` at a pivot that is not positive and finite.
fn dense_lu(mut a: MatMut<'_, f64>) -> Result<(), usize> {
    let n = a.nrows();
    if n <= 16 {
        for k in 0..n {
            let pivot = a[(k, k)];
            if !(pivot > 0.0 && pivot.is_finite()) {
                return Err(k);
            }
            for i in k + 1..n {
                a[(i, k)] /= pivot;
            }
            for j in k + 1..n {
                let x = a[(k, j)];
                for i in k + 1..n {
                    let l = a[(i, k)];
                    a[(i, j)] -= l * x;
                }
            }
        }
        return Ok(());
    }
    let h = n / 2;
    let (mut a11, mut a12, mut a21, a22) = a.split_at_mut(h, h);
    dense_lu(a11.rb_mut())?;
    solve_unit_lower_triangular_in_place(a11.rb(), a12.rb_mut(), Par::Seq);
    solve_lower_triangular_in_place(a11.rb().transpose(), a21.rb_mut().transpose_mut(), Par::Seq);
    let mut a22 = a22;
    matmul(a22.rb_mut(), Accum::Add, a21.rb(), a12.rb(), -1.0, Par::Seq);
    dense_lu(a22).map_err(|i| i + h)
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    /// Deterministic pseudo-random numbers in `[0, 1)`.
    fn noise(state: &mut u64) -> f64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    /// An `m x m` triangulated grid's M-matrix as the parameterization
    /// makes them: each row's weights positive and different each way along
    /// an edge, spread over orders of magnitude, the diagonal their sum
    /// (plus a pull towards fixed neighbours on the border). Column
    /// pointers, row indices and values.
    fn grid(m: usize, state: &mut u64) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
        let n = m * m;
        let mut columns: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
        for j in 0..m {
            for i in 0..m {
                let v = j * m + i;
                let mut diagonal = 0.0;
                for (di, dj) in [(-1, 0), (1, 0), (0, -1), (0, 1), (1, 1), (-1, -1)] {
                    let w = 10f64.powf(6.0 * noise(state) - 3.0);
                    diagonal += w;
                    let (a, b) = (i as isize + di, j as isize + dj);
                    if (0..m as isize).contains(&a) && (0..m as isize).contains(&b) {
                        columns[b as usize * m + a as usize].push((v, -w));
                    }
                }
                columns[v].push((v, diagonal));
            }
        }
        let (mut col_ptr, mut row_idx, mut values) = (vec![0], Vec::new(), Vec::new());
        for mut column in columns {
            column.sort_by_key(|e| e.0);
            row_idx.extend(column.iter().map(|e| e.0));
            values.extend(column.iter().map(|e| e.1));
            col_ptr.push(row_idx.len());
        }
        (col_ptr, row_idx, values)
    }

    /// The solution solves the system to rounding, on grids of one unknown
    /// (for which faer makes no supernodes), small enough to be one
    /// supernode and large enough for many.
    #[test]
    fn solves_m_matrices_of_symmetric_pattern() {
        let mut state = 3;
        for m in [1, 3, 40] {
            let n = m * m;
            let (col_ptr, row_idx, values) = grid(m, &mut state);
            let pattern = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
            let symbolic = Symbolic::new(pattern).unwrap();
            let mut numeric = Numeric::default();
            symbolic.factorize(&values, &mut numeric).unwrap();
            let b = Mat::<f64>::from_fn(n, 2, |_, _| noise(&mut state) - 0.5);
            let mut x = b.clone();
            symbolic.solve(&numeric, x.as_mut());
            // The residual A x - b, row by row.
            let mut residual = b.clone();
            for j in 0..n {
                for k in col_ptr[j]..col_ptr[j + 1] {
                    for c in 0..2 {
                        residual[(row_idx[k], c)] -= values[k] * x[(j, c)];
                    }
                }
            }
            let scale = (0..n)
                .map(|j| {
                    (col_ptr[j]..col_ptr[j + 1])
                        .map(|k| values[k].abs())
                        .sum::<f64>()
                })
                .fold(0.0, f64::max);
            for i in 0..n {
                for c in 0..2 {
                    assert!(
                        residual[(i, c)].abs() < 1e-12 * scale,
                        "m {m}: residual {:e} at {i}",
                        residual[(i, c)]
                    );
                }
            }
            if m > 3 {
                assert!(symbolic.supernodes() > 10, "{}", symbolic.supernodes());
            }
        }
    }

    /// The structure of `pattern` without a split: all on one thread.
    fn one_thread(pattern: SymbolicSparseColMatRef<'_, usize>) -> Symbolic {
        Symbolic {
            split: Vec::new(),
            ..Symbolic::new(pattern).unwrap()
        }
    }

    /// The bits of each value.
    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    /// Factors `values` with both structures, and checks that the factors
    /// are the same bit for bit.
    fn same_factors(split: &Symbolic, one: &Symbolic, values: &[f64]) -> (Numeric, Numeric) {
        let (mut a, mut b) = (Numeric::default(), Numeric::default());
        split.factorize(values, &mut a).unwrap();
        one.factorize(values, &mut b).unwrap();
        assert_eq!(bits(&a.l), bits(&b.l));
        assert_eq!(bits(&a.u), bits(&b.u));
        (a, b)
    }

    /// The halves factored in parallel give the factors and solutions of
    /// one thread, bit for bit, and the split is real: whole subtrees in
    /// both halves, holding most of the work.
    #[test]
    fn parallel_halves_factor_as_one_thread_does() {
        let mut state = 7;
        let m = 60;
        let n = m * m;
        let (col_ptr, row_idx, values) = grid(m, &mut state);
        let pattern = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let split = Symbolic::new(pattern).unwrap();
        assert!(split.split.len() >= 2, "{:?}", split.split);
        for half in 0..2 {
            assert!(
                split.split.iter().any(|&(_, h)| h == half),
                "{:?}",
                split.split
            );
        }
        let in_split: usize = split.split.iter().map(|(r, _)| r.len()).sum();
        assert!(
            2 * in_split > split.supernodes(),
            "{in_split} of {}",
            split.supernodes()
        );
        let one = one_thread(pattern);
        let (a, b) = same_factors(&split, &one, &values);
        let rhs = Mat::<f64>::from_fn(n, 2, |_, _| noise(&mut state) - 0.5);
        let (mut x, mut y) = (rhs.clone(), rhs.clone());
        split.solve(&a, x.as_mut());
        one.solve(&b, y.as_mut());
        for i in 0..n {
            for c in 0..2 {
                assert_eq!(x[(i, c)].to_bits(), y[(i, c)].to_bits(), "{i} {c}");
            }
        }
    }

    /// The M-matrix of a graph on `n` vertices: each edge weighted each way
    /// at random, the diagonal the row's sum plus one. Column pointers, row
    /// indices and values.
    fn graph(
        n: usize,
        edges: &[(usize, usize)],
        state: &mut u64,
    ) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
        let mut columns: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
        let mut diagonal = vec![1.0; n];
        let mut edges: Vec<(usize, usize)> = edges
            .iter()
            .filter(|e| e.0 != e.1)
            .map(|&(a, b)| (a.min(b), a.max(b)))
            .collect();
        edges.sort_unstable();
        edges.dedup();
        for (a, b) in edges {
            for (from, to) in [(a, b), (b, a)] {
                let w = 10f64.powf(4.0 * noise(state) - 2.0);
                columns[to].push((from, -w));
                diagonal[from] += w;
            }
        }
        let (mut col_ptr, mut row_idx, mut values) = (vec![0], Vec::new(), Vec::new());
        for (j, mut column) in columns.into_iter().enumerate() {
            column.push((j, diagonal[j]));
            column.sort_by_key(|e| e.0);
            row_idx.extend(column.iter().map(|e| e.0));
            values.extend(column.iter().map(|e| e.1));
            col_ptr.push(row_idx.len());
        }
        (col_ptr, row_idx, values)
    }

    /// Whether every subtree of the supernodes' elimination tree is one
    /// range of supernodes.
    fn postordered(symbolic: &Symbolic) -> bool {
        let supernodes = symbolic.supernodes();
        let owner = |r: usize| symbolic.begin.partition_point(|&b| b <= r) - 1;
        let parent: Vec<Option<usize>> = (0..supernodes)
            .map(|s| symbolic.rows_of(s).first().map(|&r| owner(r)))
            .collect();
        let mut size = vec![1usize; supernodes];
        for s in 0..supernodes {
            if let Some(p) = parent[s] {
                size[p] += size[s];
            }
        }
        (0..supernodes).all(|s| parent[s].is_none_or(|p| s + 1 - size[s] >= p + 1 - size[p]))
    }

    /// On graphs with local and long edges (whose orderings are often not
    /// postorders) the halves factor as one thread does, bit for bit, and a
    /// pivot that fails is reported where one thread meets it first, also
    /// with two failing pivots, in a top separator and a later subtree.
    #[test]
    fn irregular_trees_split_only_into_whole_subtrees() {
        let mut state = 11;
        let (mut split_trees, mut mixed_trees, mut failures) = (0, 0, 0);
        for _ in 0..300 {
            let n = 64 + (noise(&mut state) * 400.0) as usize;
            let mut edges = Vec::new();
            for i in 0..n {
                for _ in 0..3 {
                    let step = if noise(&mut state) < 0.9 {
                        1 + (noise(&mut state) * 8.0) as usize
                    } else {
                        (noise(&mut state) * n as f64) as usize
                    };
                    edges.push((i, (i + step) % n));
                }
            }
            let (col_ptr, row_idx, values) = graph(n, &edges, &mut state);
            let pattern = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
            let split = Symbolic::new(pattern).unwrap();
            if split.split.is_empty() {
                continue;
            }
            split_trees += 1;
            mixed_trees += usize::from(!postordered(&split));
            let one = one_thread(pattern);
            let (mut a, mut b) = same_factors(&split, &one, &values);
            // A separator before the last subtree, and that subtree.
            let in_split = |s: usize| split.split.iter().any(|(r, _)| r.contains(&s));
            let last = split.split.last().unwrap().0.start;
            if let Some(top) = (0..last).find(|&s| !in_split(s)) {
                failures += 1;
                let mut broken = values.clone();
                for position in [split.begin[top], split.begin[last]] {
                    let u = split.forward[position];
                    let k = (col_ptr[u]..col_ptr[u + 1]).find(|&k| row_idx[k] == u);
                    broken[k.unwrap()] = f64::NAN;
                }
                let expected = one.factorize(&broken, &mut b);
                assert!(expected.is_err());
                assert_eq!(split.factorize(&broken, &mut a), expected);
                // The rerun on one thread starts from the matrix again: it
                // leaves what one thread leaves where it stopped.
                assert!(bits(&a.l) == bits(&b.l) && bits(&a.u) == bits(&b.u));
            }
        }
        assert!(
            split_trees > 100 && mixed_trees > 10 && failures > 10,
            "{split_trees} {mixed_trees} {failures}"
        );
    }

    /// A pivot that vanishes is reported, not divided by.
    #[test]
    fn a_vanishing_pivot_is_an_error() {
        let (col_ptr, row_idx) = (vec![0, 2, 4], vec![0, 1, 0, 1]);
        let pattern = SymbolicSparseColMatRef::new_checked(2, 2, &col_ptr, None, &row_idx);
        let symbolic = Symbolic::new(pattern).unwrap();
        let mut numeric = Numeric::default();
        assert_eq!(
            symbolic.factorize(&[1.0, 1.0, 1.0, 1.0], &mut numeric),
            Err(1)
        );
        assert_eq!(
            symbolic.factorize(&[2.0, -1.0, -1.0, 2.0], &mut numeric),
            Ok(())
        );
    }
}
