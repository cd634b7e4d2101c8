//! Stencil tables: each output point is a weighted sum of input points. Built once from
//! topology alone; applied to positions or any other per-vertex data, in parallel.

use rayon::prelude::*;

/// Floating-point element types that primvars may use; sums are accumulated in `f64`.
pub trait Real: Copy + Send + Sync + Default + 'static {
    /// Widens to f64.
    fn to_f64(self) -> f64;
    /// Narrows from f64 (round to nearest).
    fn from_f64(x: f64) -> Self;
}

impl Real for f32 {
    #[inline]
    fn to_f64(self) -> f64 {
        self as f64
    }
    #[inline]
    fn from_f64(x: f64) -> Self {
        x as f32
    }
}

impl Real for f64 {
    #[inline]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline]
    fn from_f64(x: f64) -> Self {
        x
    }
}

/// A sparse matrix in compressed rows: row `i` is output point `i`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StencilTable {
    /// Row ranges into `indices` / `weights`; length rows + 1.
    pub offsets: Vec<u32>,
    /// Input point of each term.
    pub indices: Vec<u32>,
    /// Weight of each term.
    pub weights: Vec<f64>,
    /// Number of input points the table reads.
    pub num_inputs: usize,
}

impl StencilTable {
    /// An empty table reading `num_inputs` points.
    pub fn new(num_inputs: usize) -> Self {
        StencilTable {
            offsets: vec![0],
            indices: Vec::new(),
            weights: Vec::new(),
            num_inputs,
        }
    }

    /// Number of output points.
    pub fn len(&self) -> usize {
        self.offsets.len() - 1
    }

    /// True when the table has no rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Terms of row `i`.
    pub fn row(&self, i: usize) -> (&[u32], &[f64]) {
        let (a, b) = (self.offsets[i] as usize, self.offsets[i + 1] as usize);
        (&self.indices[a..b], &self.weights[a..b])
    }

    /// Appends a row; the terms are taken from the accumulator, which is cleared.
    pub fn push_row(&mut self, acc: &mut Accumulator) {
        for &(i, w) in acc.terms() {
            if w != 0.0 {
                self.indices.push(i);
                self.weights.push(w);
            }
        }
        self.offsets.push(self.indices.len() as u32);
        acc.clear();
    }

    /// Appends the rows of `other` (which must read the same inputs).
    pub fn append(&mut self, other: &StencilTable) {
        if other.offsets.len() <= 1 {
            return;
        }
        let base = self.indices.len() as u32;
        self.indices.extend_from_slice(&other.indices);
        self.weights.extend_from_slice(&other.weights);
        self.offsets
            .extend(other.offsets[1..].iter().map(|&o| o + base));
    }

    /// The rows of `parts` one after another, in one allocation per array.
    pub fn concat<'a>(
        num_inputs: usize,
        parts: impl IntoIterator<Item = &'a StencilTable> + Clone,
    ) -> Self {
        let mut table = StencilTable::new(num_inputs);
        table.reserve(
            parts.clone().into_iter().map(|p| p.len()).sum(),
            parts.clone().into_iter().map(|p| p.indices.len()).sum(),
        );
        for p in parts {
            table.append(p);
        }
        table
    }

    /// Reserves room for `rows` more rows of `terms` terms in all.
    pub fn reserve(&mut self, rows: usize, terms: usize) {
        self.offsets.reserve(rows);
        self.indices.reserve(terms);
        self.weights.reserve(terms);
    }

    /// Appends a row given as `(input, weight)` terms (taken as they are).
    pub fn push_terms(&mut self, terms: &[(u32, f64)]) {
        self.push_iter(terms.iter().copied());
    }

    /// Appends one stencil from its terms `(input, weight)`, as [`Self::push_terms`].
    pub fn push_iter(&mut self, terms: impl IntoIterator<Item = (u32, f64)>) {
        for (i, w) in terms {
            self.indices.push(i);
            self.weights.push(w);
        }
        self.offsets.push(self.indices.len() as u32);
    }

    /// Bytes used by the table.
    pub fn bytes(&self) -> usize {
        self.offsets.len() * 4 + self.indices.len() * 4 + self.weights.len() * 8
    }

    /// Applies the table to `src` (points of `width` components each) and returns the output
    /// points, computed in parallel.
    pub fn apply<T: Real>(&self, src: &[T], width: usize) -> Vec<T> {
        let mut dst = vec![T::default(); self.len() * width];
        self.apply_into(src, width, &mut dst);
        dst
    }

    /// Like [`Self::apply`], writing into `dst` (length rows × width).
    pub fn apply_into<T: Real>(&self, src: &[T], width: usize, dst: &mut [T]) {
        assert_eq!(src.len(), self.num_inputs * width, "input length mismatch");
        assert_eq!(dst.len(), self.len() * width, "output length mismatch");
        if width == 0 {
            return;
        }
        const CHUNK: usize = 1024;
        let (offsets, indices, weights) = (&self.offsets, &self.indices, &self.weights);
        let fill = |c: usize, out: &mut [T]| {
            let first = c * CHUNK;
            let rows = out.len() / width;
            let offs = &offsets[first..first + rows + 1];
            if width == 3 {
                // The common case (positions): fixed-width inner loop.
                for (k, o) in out.chunks_exact_mut(3).enumerate() {
                    let (a, b) = (offs[k] as usize, offs[k + 1] as usize);
                    let mut s = [0.0f64; 3];
                    for (&i, &wt) in indices[a..b].iter().zip(&weights[a..b]) {
                        let p = &src[i as usize * 3..i as usize * 3 + 3];
                        s[0] += wt * p[0].to_f64();
                        s[1] += wt * p[1].to_f64();
                        s[2] += wt * p[2].to_f64();
                    }
                    o[0] = T::from_f64(s[0]);
                    o[1] = T::from_f64(s[1]);
                    o[2] = T::from_f64(s[2]);
                }
                return;
            }
            let mut sum = vec![0.0f64; width];
            for (k, o) in out.chunks_exact_mut(width).enumerate() {
                let (a, b) = (offs[k] as usize, offs[k + 1] as usize);
                sum.fill(0.0);
                for (&i, &wt) in indices[a..b].iter().zip(&weights[a..b]) {
                    let p = &src[i as usize * width..i as usize * width + width];
                    for (acc, &x) in sum.iter_mut().zip(p) {
                        *acc += wt * x.to_f64();
                    }
                }
                for (d, &x) in o.iter_mut().zip(sum.iter()) {
                    *d = T::from_f64(x);
                }
            }
        };
        if self.len() <= CHUNK {
            // One chunk (a local neighbourhood's table): no thread hand-off.
            fill(0, dst);
        } else {
            dst.par_chunks_mut(CHUNK * width)
                .with_min_len(crate::threads::min_len())
                .enumerate()
                .for_each(|(c, out)| fill(c, out));
        }
    }

    /// Applies the table to 3-D points.
    pub fn apply_points(&self, src: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut out = vec![[0.0; 3]; self.len()];
        self.apply_into(src.as_flattened(), 3, out.as_flattened_mut());
        out
    }
}

/// Collects the weighted terms of one stencil row, merging repeated inputs. Rows are short
/// (a vertex's one-ring), so a linear search beats hashing.
#[derive(Clone, Debug, Default)]
pub struct Accumulator {
    terms: Vec<(u32, f64)>,
}

impl Accumulator {
    /// An empty accumulator.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds `w` times input `i`.
    #[inline]
    pub fn add(&mut self, i: u32, w: f64) {
        if let Some(t) = self.terms.iter_mut().find(|t| t.0 == i) {
            t.1 += w;
        } else {
            self.terms.push((i, w));
        }
    }

    /// Removes all terms.
    pub fn clear(&mut self) {
        self.terms.clear();
    }

    /// The current terms (input, weight), in the order first added.
    pub fn terms(&self) -> &[(u32, f64)] {
        &self.terms
    }
}
