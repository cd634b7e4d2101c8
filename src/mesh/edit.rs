//! RenderMan's hierarchical edits (paper 001 §6.3; OpenSubdiv's Hbr and the OBJ tags
//! `vertexedit`, `edgeedit` and `faceedit`): changes to a vertex, edge or face that exists only
//! after some refinement, reached from a control face by a path of sub-face indices.
//!
//! Sub-face `k` of a face is the child at the face's corner `k`; a Catmull-Clark child quad's
//! corners are (child of corner `k`, edge point of edge `k`, face point, edge point of edge
//! `k − 1`) and its edge `j` runs from its corner `j` to corner `j + 1` (the ptex convention,
//! [`crate::refine::step`]). An edit on a path of `n` sub-face indices acts at level `n`, on
//! the element as it is created, before it is refined further.

/// How an edit combines its value with the element's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EditOp {
    /// Replace the value.
    Set,
    /// Add to the value.
    Add,
    /// Subtract from the value.
    Subtract,
}

impl EditOp {
    /// `current` changed by `value` under this operation.
    pub fn apply(self, current: f64, value: f64) -> f64 {
        match self {
            EditOp::Set => value,
            EditOp::Add => current + value,
            EditOp::Subtract => current - value,
        }
    }
}

/// What an edit changes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EditKind {
    /// The position of the sub-face's corner `corner`.
    Position {
        /// Corner of the sub-face.
        corner: u32,
        /// Operation.
        op: EditOp,
        /// Value (a point for `Set`, an offset otherwise).
        value: [f64; 3],
    },
    /// The sharpness of the sub-face's corner `corner`.
    VertexSharpness {
        /// Corner of the sub-face.
        corner: u32,
        /// Operation.
        op: EditOp,
        /// Value.
        value: f32,
    },
    /// The sharpness of the sub-face's edge `edge` (from its corner `edge` to the next).
    EdgeSharpness {
        /// Edge of the sub-face.
        edge: u32,
        /// Operation.
        op: EditOp,
        /// Value.
        value: f32,
    },
    /// The sub-face is a hole, and so is everything refined from it.
    Hole,
}

/// One hierarchical edit: a sub-face and what changes on it.
#[derive(Clone, Debug, PartialEq)]
pub struct HierarchicalEdit {
    /// The control face the path starts from (0-based).
    pub face: u32,
    /// Sub-face indices, one per refinement level; the edit acts at level `path.len()`.
    pub path: Vec<u32>,
    /// What changes.
    pub kind: EditKind,
}

impl HierarchicalEdit {
    /// An edit of `kind` on the sub-face reached from control face `face` by `path`.
    pub fn new(face: u32, path: &[u32], kind: EditKind) -> Self {
        HierarchicalEdit {
            face,
            path: path.to_vec(),
            kind,
        }
    }

    /// The refinement level the edit acts at.
    pub fn level(&self) -> usize {
        self.path.len()
    }

    /// The index of the corner or edge the edit names (`None` for a face edit).
    pub fn element(&self) -> Option<u32> {
        match self.kind {
            EditKind::Position { corner, .. } | EditKind::VertexSharpness { corner, .. } => {
                Some(corner)
            }
            EditKind::EdgeSharpness { edge, .. } => Some(edge),
            EditKind::Hole => None,
        }
    }
}
