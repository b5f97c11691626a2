//! Typed indices for vertices, faces and edges.
//!
//! All three are `u32` newtypes so that the three index spaces cannot be confused and so that
//! connectivity arrays stay compact (a mesh is limited to `u32::MAX - 1` vertices / faces).

use std::fmt;

macro_rules! typed_id {
    ($(#[$doc:meta])* $name:ident, $prefix:literal) => {
        $(#[$doc])*
        #[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub struct $name(pub u32);

        impl $name {
            /// The index as `usize`, for indexing slices.
            #[inline]
            pub fn idx(self) -> usize {
                self.0 as usize
            }

            /// Wraps a `usize` index.
            ///
            /// Indices above `u32::MAX` are truncated; meshes are limited to `u32` indices
            /// (checked by [`Mesh::new`](crate::Mesh::new)).
            #[inline]
            pub fn new(i: usize) -> Self {
                debug_assert!(i <= u32::MAX as usize, "index {i} does not fit in u32");
                Self(i as u32)
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, concat!($prefix, "{}"), self.0)
            }
        }
    };
}

typed_id!(
    /// Index of a vertex of a [`Mesh`](crate::Mesh) (position in [`Mesh::positions`](crate::Mesh::positions)).
    VertexId,
    "v"
);
typed_id!(
    /// Index of a triangle of a [`Mesh`](crate::Mesh) (position in [`Mesh::faces`](crate::Mesh::faces)).
    FaceId,
    "f"
);
typed_id!(
    /// Index of an edge in [`Topology::edges`](crate::Topology::edges).
    EdgeId,
    "e"
);
