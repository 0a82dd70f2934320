//! A sparse LU factorization without pivoting, for the parameterization's
//! mean-value systems below `LU_BELOW` unknowns (module `square`).
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
//! The factorization runs on one thread (factoring subtrees of the
//! elimination tree in parallel saved too little to keep a second code
//! path); the two columns of the right-hand side are solved at once. faer's general sparse LU (partial
//! pivoting, COLAMD ordering) has to allow for any row exchange, so its
//! factors follow the pattern of `A^T A`: it was slower on the same
//! matrices, for the same solutions (docs/decisions/016-sparse-lu.md).
//!
//! Main items: [`Symbolic`] (the structure of the factors) and [`Numeric`]
//! (their values), and [`SymbolicFactorization`], the symbolic
//! factorization a disk keeps for all its solves (module `cut` stores it,
//! module `square` makes it): this LU's, or faer's Cholesky above
//! `LU_BELOW` unknowns.

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

/// A disk's symbolic factorization, of the kind its size asks for.
pub enum SymbolicFactorization {
    Lu(Symbolic),
    Cholesky(faer::sparse::linalg::cholesky::SymbolicCholesky<usize>),
}

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
}

/// The numeric factors.
#[derive(Default)]
pub struct Numeric {
    l: Vec<f64>,
    u: Vec<f64>,
    /// The rows' places in the supernode at hand (`usize::MAX` between
    /// supernodes), and room for the dense products.
    local: Vec<usize>,
    scratch: Vec<f64>,
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
        let Numeric {
            l,
            u,
            local,
            scratch,
        } = numeric;
        (0..self.supernodes()).try_for_each(|s| self.supernode(s, l, u, local, scratch))
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
        numeric.local.clear();
        numeric.local.resize(self.forward.len(), usize::MAX);
    }

    /// Factors supernode `s` (left-looking: its descendants are done).
    /// `local` is all `usize::MAX`, and left so unless a pivot fails.
    fn supernode(
        &self,
        s: usize,
        l: &mut [f64],
        u: &mut [f64],
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
        let (l_done, l_rest) = l.split_at_mut(self.values[s]);
        let (u_done, u_rest) = u.split_at_mut(self.values[s]);
        let size = self.values[s + 1] - self.values[s];
        let (ls, us) = (&mut l_rest[..size], &mut u_rest[..size]);
        for &d in &self.below[self.updates[s]..self.updates[s + 1]] {
            let d_width = self.begin[d + 1] - self.begin[d];
            let d_rows = self.rows_of(d);
            let d_height = d_width + d_rows.len();
            let span = self.values[d]..self.values[d + 1];
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
