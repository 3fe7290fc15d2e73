//! Node and block layout, and how child references are encoded.
//!
//! * **Nodes** ([`WideNode`], 224 bytes of data in 256: aligned to a cache line, so
//!   a node is four whole lines and its address a shift of its index rather than a
//!   multiply on the traversal's dependency chain) hold the boxes of up to eight children as
//!   six rows of eight floats (`lo x, hi x, lo y, hi y, lo z, hi z`), so one ray
//!   tests all eight with a handful of 8-wide operations: per ray the near and far
//!   planes of each axis are picked once by the sign of the direction. The slab
//!   test is the scalar [`crate::geometry::Aabb::intersect`] lane by lane
//!   (`(plane − o)·(1/d)`, far distances widened by 2γ(3)), on padded boxes, so
//!   it is exactly as conservative.
//! * **Triangles** ([`TriBlock`]) are stored as structure-of-arrays blocks of
//!   eight (vertex, axis, lane) with their primitive indices; short blocks repeat
//!   their last triangle. A leaf is one block: on AVX2 an 8-lane test costs what a
//!   4-lane one does, and the builder's cost model knows it, so leaves fill up
//!   (7.3 triangles on average for the bunny) and a ray tests about a third fewer
//!   blocks than with 4-lane blocks.
//! * **Child references** are `u32`s: a node index, or `LEAF` with the first
//!   block (or, with `GENERIC`, the first index into `generic`) above bit 4 and
//!   the count − 1 in the low four bits; `EMPTY` marks an unused slot.

use crate::geometry::Aabb;
use crate::math::Vec3;

pub const WIDTH: usize = 8;
/// Triangles per SIMD block.
pub const LANES: usize = 8;
/// Child reference: a leaf (else the index of a node).
pub(super) const LEAF: u32 = 1 << 31;
/// Leaf of non-triangle primitives (indices in `generic`), else of triangle blocks.
pub(super) const GENERIC: u32 = 1 << 30;
/// An unused child slot (its box is empty, so no ray reaches it).
pub(super) const EMPTY: u32 = u32::MAX;
pub(super) const INDEX_BITS: u32 = 26;

#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct WideNode {
    /// `lo x, hi x, lo y, hi y, lo z, hi z` of each child (padded boxes).
    pub planes: [[f32; WIDTH]; 6],
    pub child: [u32; WIDTH],
}

impl WideNode {
    pub(super) const EMPTY: WideNode = WideNode {
        planes: [
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
        ],
        child: [EMPTY; WIDTH],
    };

    /// Box of child `i` (empty for an unused slot).
    pub fn child_bounds(&self, i: usize) -> Aabb {
        let p = &self.planes;
        Aabb::new(Vec3::new(p[0][i], p[2][i], p[4][i]), Vec3::new(p[1][i], p[3][i], p[5][i]))
    }
}

/// Eight triangles, structure of arrays: `v[vertex][axis][lane]`.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct TriBlock {
    pub v: [[[f32; LANES]; 3]; 3],
    /// Primitive index of each lane (a short block repeats its last triangle).
    pub prim: [u32; LANES],
}

impl TriBlock {
    /// The lane's vertices (spelt out rather than `[0, 1, 2].map(…)`, whose
    /// `try_map` the portable block test did not always get inlined).
    #[inline]
    pub fn triangle(&self, lane: usize) -> [Vec3; 3] {
        let v = |k: usize| Vec3::new(self.v[k][0][lane], self.v[k][1][lane], self.v[k][2][lane]);
        [v(0), v(1), v(2)]
    }
}

/// A decoded child reference.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChildRef {
    Node(usize),
    /// `count` triangle blocks from `first`.
    Triangles {
        first: usize,
        count: usize,
    },
    /// `count` primitive indices from `first` in `generic`.
    Generic {
        first: usize,
        count: usize,
    },
}

pub(super) fn decode(c: u32) -> ChildRef {
    let (first, count) = (((c & !(LEAF | GENERIC)) >> 4) as usize, (c & 15) as usize + 1);
    if c & LEAF == 0 {
        ChildRef::Node(c as usize)
    } else if c & GENERIC != 0 {
        ChildRef::Generic { first, count }
    } else {
        ChildRef::Triangles { first, count }
    }
}

#[inline(always)]
pub(super) fn leaf_range(c: u32) -> (usize, usize) {
    (((c & !(LEAF | GENERIC)) >> 4) as usize, (c & 15) as usize + 1)
}
