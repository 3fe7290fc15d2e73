//! The renderer's acceleration structure: an 8-wide BVH collapsed from the binned
//! SAH tree of [`super::build`], with triangles stored eight to a SIMD block.
//!
//! * `collapse`: which binary subtrees become the children of each wide node, by
//!   SAH cost (Ylitie et al. 2017), the same tree for any number of threads;
//! * [`node`]: the node layout ([`WideNode`], eight boxes as six rows of eight
//!   floats), the triangle blocks ([`TriBlock`]) and the child references;
//! * `traverse`: front-to-back closest-hit and any-hit traversal, generic over
//!   a kernel trait (node and block tests of one instruction set), and the
//!   portable kernels;
//! * `x86`: the AVX2 and AVX-512 kernels, bit-identical to the scalar ones, and
//!   the `#[target_feature]` entry points that instantiate the traversal with
//!   them (the dependency goes one way: `x86` uses `traverse`);
//! * `packet`: coherent rays traversed together ([`WideBvh::intersect_packet`],
//!   [`WideBvh::occluded_packet`]), generic over SIMD lanes across rays, with
//!   the single-ray results; `packet_x86` holds its AVX2 / AVX-512 lanes.
//!
//! Instruction sets ([`Isa`]) are picked at run time; the portable one runs
//! everywhere and can be forced with [`WideBvh::set_isa`] (the tests run every
//! variant the machine has).
//!
//! Spheres (and any primitive that is not a triangle) sit in separate leaves of
//! primitive indices tested with their own kernel.

mod collapse;
pub mod node;
mod packet;
#[cfg(target_arch = "x86_64")]
mod packet_x86;
mod traverse;
#[cfg(target_arch = "x86_64")]
mod x86;

pub use node::{ChildRef, TriBlock, WideNode, LANES, WIDTH};
pub use packet::{PacketHits, PACKET};

use crate::accel::build::{self, PrimRef};
use crate::accel::presplit;
use crate::geometry::prim::{Hit, Prim};
use crate::geometry::{Aabb, Ray};
use node::{decode, EMPTY};
use packet::{any_packet, closest_packet, Lanes};
use std::sync::atomic::{AtomicU64, Ordering};
pub use traverse::Leaves;
use traverse::{any, closest, Portable};

/// Trees of at most this many primitives (a Cornell box and the like) get leaves of
/// at most [`SMALL_TREE_LEAF`]: their rays are mostly camera and shadow packets, which
/// test a leaf triangle by triangle, so smaller leaves with tighter boxes cull more
/// (cbox_point −6 %, caustic_cbox −4.5 %, cbox_path ±0); larger trees keep blocks of
/// eight, which single rays test at once (leaves of four cost the bunny's rays 10–30 %).
pub const SMALL_TREE: usize = 64;
pub const SMALL_TREE_LEAF: usize = 2;

/// Stack sizes: the small one serves every tree whose worst path needs it.
const STACK_SMALL: usize = 128;
const STACK_LARGE: usize = 1024;

/// Instruction set of the traversal kernels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Isa {
    Portable,
    Avx2,
    Avx512,
}

impl Isa {
    /// The best the CPU has.
    pub fn detect() -> Isa {
        [Isa::Avx512, Isa::Avx2]
            .into_iter()
            .find(|i| i.available())
            .unwrap_or(Isa::Portable)
    }

    pub fn available(self) -> bool {
        match self {
            Isa::Portable => true,
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma"),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => Isa::Avx2.available() && is_x86_feature_detected!("avx512f") && is_x86_feature_detected!("avx512vl"),
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// Runs `f` compiled for this instruction set where the CPU has it (else as it is):
    /// once `f` is inlined into the set's copy, the compiler may turn its lane-by-lane
    /// loops into the set's vector instructions. The results stay bit for bit the same:
    /// every operation is still exact IEEE arithmetic (no contraction into FMA).
    #[inline(always)]
    pub fn run<R>(self, f: impl FnOnce() -> R) -> R {
        #[cfg(target_arch = "x86_64")]
        match self {
            // SAFETY: the CPU has AVX-512F+VL, AVX2 and FMA (`available`, checked here).
            Isa::Avx512 if self.available() => return unsafe { run_avx512(f) },
            // SAFETY: the CPU has AVX2 and FMA (as above).
            Isa::Avx2 if self.available() => return unsafe { run_avx2(f) },
            _ => {}
        }
        f()
    }

    /// Rays a packet traversal takes at once with these kernels unless told otherwise:
    /// 16 where a lane vector holds them all (AVX-512) and for the portable lanes; 8 on
    /// AVX2, whose 16 lanes are two vectors each and spill registers in the box tests
    /// (cbox_point 4-8 % slower than with 8 on a Zen 5, the portable kernels 7 % faster
    /// with 16).
    pub fn packet_width(self) -> usize {
        match self {
            Isa::Avx2 => 8,
            Isa::Portable | Isa::Avx512 => PACKET,
        }
    }

    /// Every variant this CPU can run.
    pub fn all_available() -> Vec<Isa> {
        [Isa::Portable, Isa::Avx2, Isa::Avx512]
            .into_iter()
            .filter(|i| i.available())
            .collect()
    }

    pub fn name(self) -> &'static str {
        match self {
            Isa::Portable => "portable",
            Isa::Avx2 => "avx2",
            Isa::Avx512 => "avx512",
        }
    }
}

/// [`Isa::run`]'s AVX-512 copy.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
fn run_avx512<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// [`Isa::run`]'s AVX2 copy.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn run_avx2<R>(f: impl FnOnce() -> R) -> R {
    f()
}

#[derive(Debug)]
pub struct WideBvh {
    /// Node 0 is the root (no nodes: nothing to hit).
    pub nodes: Vec<WideNode>,
    pub blocks: Vec<TriBlock>,
    /// Primitive indices of the generic leaves.
    pub generic: Vec<u32>,
    /// Bounds of everything (unpadded).
    root_bounds: Aabb,
    /// Primitives in the tree.
    pub prim_count: usize,
    isa: Isa,
    /// Deepest traversal stack any ray can need.
    stack_need: usize,
    /// Use the large stack even where the small one would do (tests).
    large_stack: bool,
    /// Rays a packet traversal takes at once (8 or 16; 0: packet calls trace ray by
    /// ray), where set; else the instruction set's own ([`Isa::packet_width`]).
    packet_width: Option<usize>,
    /// Where closest-hit queries are recorded (`rdr bench --record-rays`), if anywhere.
    pub log: Option<std::sync::Arc<crate::accel::record::RayLog>>,
}

/// A clone keeps the node and block arrays on huge pages (`pages`).
impl Clone for WideBvh {
    fn clone(&self) -> Self {
        WideBvh {
            nodes: crate::pages::clone_huge(&self.nodes),
            blocks: crate::pages::clone_huge(&self.blocks),
            generic: self.generic.clone(),
            root_bounds: self.root_bounds,
            prim_count: self.prim_count,
            isa: self.isa,
            stack_need: self.stack_need,
            large_stack: self.large_stack,
            packet_width: self.packet_width,
            log: self.log.clone(),
        }
    }
}

impl Default for WideBvh {
    fn default() -> Self {
        WideBvh {
            nodes: Vec::new(),
            blocks: Vec::new(),
            generic: Vec::new(),
            root_bounds: Aabb::EMPTY,
            prim_count: 0,
            isa: Isa::detect(),
            stack_need: 1,
            large_stack: false,
            packet_width: None,
            log: None,
        }
    }
}

/// Calls a traversal for the tree's instruction set and stack size: the
/// portable body `$portable::<Portable, S>` or the x86 entry points
/// `x86::$avx2::<S>` / `x86::$avx512::<S>`, with `S` the small stack where it
/// is enough.
macro_rules! dispatch {
    ($bvh:expr, $portable:ident, $avx2:ident, $avx512:ident, ($($arg:expr),*)) => {{
        let small = $bvh.stack_need <= STACK_SMALL && !$bvh.large_stack;
        match $bvh.isa {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `isa` is only ever set to an instruction set the CPU has (`set_isa`, `Isa::detect`).
            Isa::Avx512 => unsafe {
                if small {
                    x86::$avx512::<_, STACK_SMALL>($($arg),*)
                } else {
                    x86::$avx512::<_, STACK_LARGE>($($arg),*)
                }
            },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            Isa::Avx2 => unsafe {
                if small {
                    x86::$avx2::<_, STACK_SMALL>($($arg),*)
                } else {
                    x86::$avx2::<_, STACK_LARGE>($($arg),*)
                }
            },
            _ => {
                if small {
                    $portable::<Portable, _, STACK_SMALL>($($arg),*)
                } else {
                    $portable::<Portable, _, STACK_LARGE>($($arg),*)
                }
            }
        }
    }};
}

/// The packet traversals' [`dispatch!`]: instruction set, then width
/// (`$p8`/`$p16` the x86 entry points of 8 and 16 lanes), then stack size.
macro_rules! dispatch_packet {
    ($bvh:expr, $portable:ident, [$a8:ident, $a16:ident], [$z8:ident, $z16:ident], ($($arg:expr),*)) => {{
        let small = $bvh.stack_need <= STACK_SMALL && !$bvh.large_stack;
        let wide = $bvh.packet_width() > 8;
        match $bvh.isa {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `isa` is only ever set to an instruction set the CPU has (`set_isa`, `Isa::detect`).
            Isa::Avx512 => unsafe {
                match (wide, small) {
                    (true, true) => packet_x86::$z16::<_, STACK_SMALL>($($arg),*),
                    (true, false) => packet_x86::$z16::<_, STACK_LARGE>($($arg),*),
                    (false, true) => packet_x86::$z8::<_, STACK_SMALL>($($arg),*),
                    (false, false) => packet_x86::$z8::<_, STACK_LARGE>($($arg),*),
                }
            },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            Isa::Avx2 => unsafe {
                match (wide, small) {
                    (true, true) => packet_x86::$a16::<_, STACK_SMALL>($($arg),*),
                    (true, false) => packet_x86::$a16::<_, STACK_LARGE>($($arg),*),
                    (false, true) => packet_x86::$a8::<_, STACK_SMALL>($($arg),*),
                    (false, false) => packet_x86::$a8::<_, STACK_LARGE>($($arg),*),
                }
            },
            _ => match (wide, small) {
                (true, true) => $portable::<Lanes<16>, _, 16, STACK_SMALL>($($arg),*),
                (true, false) => $portable::<Lanes<16>, _, 16, STACK_LARGE>($($arg),*),
                (false, true) => $portable::<Lanes<8>, _, 8, STACK_SMALL>($($arg),*),
                (false, false) => $portable::<Lanes<8>, _, 8, STACK_LARGE>($($arg),*),
            },
        }
    }};
}

/// Closest-hit rays of packets traced again alone (near ties, see `packet`).
static PACKET_RETRACED: AtomicU64 = AtomicU64::new(0);

/// How many rays of closest-hit packets were traced again by the single-ray kernel.
pub fn packet_retraced() -> u64 {
    PACKET_RETRACED.load(Ordering::Relaxed)
}

/// Rays with a NaN or infinite origin or direction (or a NaN range) seen by
/// [`WideBvh::intersect`] and [`WideBvh::occluded`], which treat them as misses.
static INVALID_RAYS: AtomicU64 = AtomicU64::new(0);

/// How many NaN or infinite rays traversal has refused so far in this process.
pub fn invalid_rays() -> u64 {
    INVALID_RAYS.load(Ordering::Relaxed)
}

/// Whether a ray can be traversed: finite origin and direction, a range that is not
/// NaN. Others miss (and are counted): their box tests would give NaN distances and
/// masks that admit empty child slots. Good rays pay five adds and two compares (a
/// sum is finite only when every term is, and `t_max >= t_min` is false for NaN).
#[inline(always)]
fn usable(ray: &Ray) -> bool {
    let s = (ray.o.x + ray.o.y) + (ray.o.z + ray.d.x) + (ray.d.y + ray.d.z);
    if s.is_finite() && ray.t_max >= ray.t_min {
        return true;
    }
    refused(ray)
}

/// The rare path of [`usable`]: an empty range is a plain miss; anything else (NaN or
/// infinite values, or coordinates so close to `f32::MAX` that their sum overflows)
/// is counted.
#[cold]
#[inline(never)]
fn refused(ray: &Ray) -> bool {
    let finite = ray.o.is_finite() && ray.d.is_finite() && !ray.t_min.is_nan() && !ray.t_max.is_nan();
    let s = (ray.o.x + ray.o.y) + (ray.o.z + ray.d.x) + (ray.d.y + ray.d.z);
    if !(finite && s.is_finite()) {
        INVALID_RAYS.fetch_add(1, Ordering::Relaxed);
    }
    false
}

impl WideBvh {
    /// Builds over `prims` (indices refer to this slice); primitives with
    /// unusable bounds (empty, NaN, infinite) are left out. A tree of at most
    /// [`SMALL_TREE`] primitives gets leaves of at most [`SMALL_TREE_LEAF`].
    /// Triangles are not pre-split: with leaves of eight-triangle blocks a few large
    /// triangles already cost one block test in a leaf near the root, and splitting
    /// them scattered their pieces through the tree (more nodes per ray on every scene
    /// measured; see [`presplit`] and `rdr bench MESH --split-budget`).
    pub fn build(prims: &[Prim]) -> WideBvh {
        Self::build_split(prims, 0.0)
    }

    /// [`WideBvh::build`] with triangles pre-split ([`presplit`]) within `budget` extra
    /// references per triangle (0: none, the tree [`WideBvh::build`] gives).
    pub fn build_split(prims: &[Prim], budget: f32) -> WideBvh {
        let refs = build::make_refs_with(prims.len(), |i| {
            let p = &prims[i];
            (p.bounds(), p.is_triangle())
        });
        let usable = refs.len();
        let mut refs = presplit::presplit(refs, budget, |i| match &prims[i as usize] {
            Prim::Triangle { p, .. } => Some(*p),
            _ => None,
        });
        let max_leaf = if prims.len() <= SMALL_TREE {
            SMALL_TREE_LEAF
        } else {
            build::MAX_LEAF
        };
        let tree = build::build_tree(&mut refs, max_leaf);
        let order: Vec<u32> = refs.iter().map(PrimRef::index).collect();
        drop(refs);
        let mut bvh = collapse::collapse(tree.as_ref(), &order, prims);
        bvh.prim_count = usable;
        bvh
    }

    /// Bounds of all primitives in the tree (empty for an empty tree).
    pub fn bounds(&self) -> Aabb {
        self.root_bounds
    }

    pub fn isa(&self) -> Isa {
        self.isa
    }

    /// Forces an instruction set; `false` (and no change) if the CPU lacks it.
    pub fn set_isa(&mut self, isa: Isa) -> bool {
        if isa.available() {
            self.isa = isa;
        }
        self.isa == isa
    }

    /// Bytes of nodes, triangle blocks and generic leaves.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<WideNode>() + self.blocks.len() * std::mem::size_of::<TriBlock>() + self.generic.len() * 4
    }

    /// Forces the traversal variants with the large stack (which deep trees
    /// use) so tests reach them on small trees too.
    #[doc(hidden)]
    pub fn set_large_stack(&mut self, on: bool) {
        self.large_stack = on;
    }

    /// Deepest stack a traversal can need.
    pub fn stack_need(&self) -> usize {
        self.stack_need
    }

    /// Closest hit in `[ray.t_min, ray.t_max]`; `prims` is the slice the tree was built over.
    #[inline]
    pub fn intersect(&self, prims: &[Prim], ray: &Ray) -> Option<Hit> {
        self.intersect_with(prims, ray)
    }

    /// Whether anything lies on the ray within `[ray.t_min, ray.t_max]`.
    #[inline]
    pub fn occluded(&self, prims: &[Prim], ray: &Ray) -> bool {
        self.occluded_with(prims, ray)
    }

    /// [`WideBvh::intersect`] with the generic leaves' primitives tested by `leaves`
    /// (triangle blocks are tested as always): the top level of a two-level
    /// structure, whose generic leaves are instances.
    pub fn intersect_with<L: Leaves + ?Sized>(&self, leaves: &L, ray: &Ray) -> Option<Hit> {
        if let Some(log) = &self.log {
            log.push(ray);
        }
        self.closest_one(leaves, ray)
    }

    /// [`WideBvh::intersect_with`], not recorded.
    #[inline(always)]
    fn closest_one<L: Leaves + ?Sized>(&self, leaves: &L, ray: &Ray) -> Option<Hit> {
        if self.nodes.is_empty() || !usable(ray) {
            return None;
        }
        dispatch!(self, closest, closest_avx2, closest_avx512, (self, leaves, ray))
    }

    /// [`WideBvh::occluded`] with the generic leaves tested by `leaves`.
    pub fn occluded_with<L: Leaves + ?Sized>(&self, leaves: &L, ray: &Ray) -> bool {
        if self.nodes.is_empty() || !usable(ray) {
            return false;
        }
        dispatch!(self, any, any_avx2, any_avx512, (self, leaves, ray))
    }

    /// Rays per packet traversal (8 or 16), 0 if packet calls trace ray by ray.
    pub fn packet_width(&self) -> usize {
        self.packet_width.unwrap_or(self.isa.packet_width())
    }

    /// Sets the packet width: 8, 16, or 0 (packet calls then trace ray by ray);
    /// `false` (and no change) for any other.
    pub fn set_packet_width(&mut self, w: usize) -> bool {
        let ok = matches!(w, 0 | 8 | 16);
        if ok {
            self.packet_width = Some(w);
        }
        ok
    }

    /// Closest hits of up to [`PACKET`] coherent rays: `out[i]` gets what
    /// [`WideBvh::intersect`] returns for `rays[i]`, for each bit `i` of `active`
    /// (other entries are left alone).
    #[inline]
    pub fn intersect_packet(&self, prims: &[Prim], rays: &[Ray], active: u32, out: &mut [Option<Hit>]) {
        self.intersect_packet_with(prims, rays, active, out)
    }

    /// Which of up to [`PACKET`] rays are occluded: bit `i` is what
    /// [`WideBvh::occluded`] returns for `rays[i]`, for each bit `i` of `active`
    /// (0 elsewhere).
    #[inline]
    pub fn occluded_packet(&self, prims: &[Prim], rays: &[Ray], active: u32) -> u32 {
        self.occluded_packet_with(prims, rays, active)
    }

    /// [`WideBvh::intersect_packet`] with generic leaves tested by `leaves`.
    pub fn intersect_packet_with<L: Leaves + ?Sized>(&self, leaves: &L, rays: &[Ray], active: u32, out: &mut [Option<Hit>]) {
        let n = rays.len().min(PACKET).min(out.len());
        let active = active & ((1u32 << n) - 1);
        let mut hits = PacketHits::default();
        self.intersect_packet_lanes_with(leaves, &rays[..n], active, &mut hits);
        for i in (0..n).filter(|i| active >> i & 1 != 0) {
            out[i] = hits.get(i);
        }
    }

    /// [`WideBvh::intersect_packet`] by lane: `out`'s lane `i` gets what
    /// [`WideBvh::intersect`] returns for `rays[i]`, for each bit `i` of `active`;
    /// other lanes are not found.
    pub fn intersect_packet_lanes_with<L: Leaves + ?Sized>(&self, leaves: &L, rays: &[Ray], active: u32, out: &mut PacketHits) {
        let n = rays.len().min(PACKET);
        let active = active & ((1u32 << n) - 1);
        out.found = 0;
        if let Some(log) = &self.log {
            (0..n).filter(|i| active >> i & 1 != 0).for_each(|i| log.push(&rays[i]));
        }
        let w = self.packet_width();
        if w == 0 || self.nodes.is_empty() {
            for i in (0..n).filter(|i| active >> i & 1 != 0) {
                out.set(i, self.closest_one(leaves, &rays[i]));
            }
            return;
        }
        let mut flagged = 0u32;
        for start in (0..n).step_by(w) {
            let end = (start + w).min(n);
            let a = active >> start & ((1u32 << (end - start)) - 1);
            if a != 0 {
                let rs = &rays[start..end];
                let f = dispatch_packet!(
                    self,
                    closest_packet,
                    [closest_avx2_8, closest_avx2_16],
                    [closest_avx512_8, closest_avx512_16],
                    (self, leaves, rs, a, out, start)
                );
                flagged |= f << start;
            }
        }
        if flagged != 0 {
            PACKET_RETRACED.fetch_add(flagged.count_ones() as u64, Ordering::Relaxed);
            for i in (0..n).filter(|i| flagged >> i & 1 != 0) {
                out.set(i, self.closest_one(leaves, &rays[i]));
            }
        }
    }

    /// [`WideBvh::occluded_packet`] with generic leaves tested by `leaves`.
    pub fn occluded_packet_with<L: Leaves + ?Sized>(&self, leaves: &L, rays: &[Ray], active: u32) -> u32 {
        let n = rays.len().min(PACKET);
        let active = active & ((1u32 << n) - 1);
        let w = self.packet_width();
        if w == 0 || self.nodes.is_empty() {
            return (0..n)
                .filter(|&i| active >> i & 1 != 0 && self.occluded_with(leaves, &rays[i]))
                .fold(0, |m, i| m | 1 << i);
        }
        let mut hit = 0u32;
        for start in (0..n).step_by(w) {
            let end = (start + w).min(n);
            let a = active >> start & ((1u32 << (end - start)) - 1);
            if a != 0 {
                let rs = &rays[start..end];
                let h = dispatch_packet!(
                    self,
                    any_packet,
                    [any_avx2_8, any_avx2_16],
                    [any_avx512_8, any_avx512_16],
                    (self, leaves, rs, a)
                );
                hit |= h << start;
            }
        }
        hit
    }

    /// Every child reference: `(node, slot, child)` for checks and statistics.
    pub fn children(&self) -> impl Iterator<Item = (usize, usize, ChildRef)> + '_ {
        self.nodes.iter().enumerate().flat_map(|(i, n)| {
            n.child
                .iter()
                .enumerate()
                .filter(|(_, &c)| c != EMPTY)
                .map(move |(s, &c)| (i, s, decode(c)))
        })
    }

    /// The tree's SAH cost: by surface area relative to the root's box, the expected
    /// number of inner nodes a ray through the root visits plus the triangle blocks and
    /// other primitives it tests (one unit each, as the builder's cost model).
    pub fn sah_cost(&self) -> f64 {
        let area = |b: &Aabb| {
            let e = (b.max - b.min).as_dvec3();
            e.x * e.y + e.y * e.z + e.z * e.x
        };
        let root = area(&self.root_bounds);
        if self.nodes.is_empty() || root <= 0.0 {
            return 0.0;
        }
        let mut cost = 1.0;
        for (node, slot, child) in self.children() {
            let p = &self.nodes[node].planes;
            let b = Aabb::new(
                crate::math::Vec3::new(p[0][slot], p[2][slot], p[4][slot]),
                crate::math::Vec3::new(p[1][slot], p[3][slot], p[5][slot]),
            );
            let units = match child {
                ChildRef::Node(_) => 1,
                ChildRef::Triangles { count, .. } | ChildRef::Generic { count, .. } => count,
            };
            cost += units as f64 * area(&b) / root;
        }
        cost
    }

    /// Primitive indices of a leaf reference (padding lanes left out).
    pub fn leaf_prims(&self, c: ChildRef) -> Vec<u32> {
        match c {
            ChildRef::Node(_) => Vec::new(),
            ChildRef::Generic { first, count } => self.generic[first..first + count].to_vec(),
            ChildRef::Triangles { first, count } => {
                let mut v = Vec::new();
                for b in &self.blocks[first..first + count] {
                    for lane in 0..LANES {
                        if lane == 0 || b.prim[lane] != b.prim[lane - 1] {
                            v.push(b.prim[lane]);
                        }
                    }
                }
                v
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

    /// The packet width follows the instruction set until one is set, then stays.
    #[test]
    fn packet_width_is_the_sets_own_until_set() {
        let mut bvh = WideBvh::default();
        for isa in Isa::all_available() {
            assert!(bvh.set_isa(isa));
            assert_eq!(bvh.packet_width(), isa.packet_width(), "{isa:?}");
        }
        assert_eq!(Isa::Avx2.packet_width(), 8);
        assert_eq!(Isa::Portable.packet_width(), PACKET);
        assert!(bvh.set_packet_width(0) && !bvh.set_packet_width(12));
        for isa in Isa::all_available() {
            assert!(bvh.set_isa(isa));
            assert_eq!(bvh.packet_width(), 0, "{isa:?}");
        }
    }

    /// `Isa::run` gives `f`'s result bit for bit with every set, those the CPU lacks too
    /// (they run `f` as it is): square roots and divisions over lanes.
    #[test]
    fn run_gives_the_same_bits_with_every_set() {
        let lanes: [f32; 64] = std::array::from_fn(|i| (i as f32 * 0.37 + 0.1).powi(3) - 5.0);
        let f = || lanes.map(|x| (x.abs().sqrt() / (x + 0.3)).to_bits());
        let plain = f();
        for isa in [Isa::Portable, Isa::Avx2, Isa::Avx512] {
            assert_eq!(isa.run(f), plain, "{isa:?}");
        }
    }

    /// Trees of up to `SMALL_TREE` primitives have leaves of at most `SMALL_TREE_LEAF`,
    /// larger ones leaves of up to eight, and both hold every primitive once.
    #[test]
    fn small_trees_have_small_leaves() {
        let grid = |n: u32| -> Vec<Prim> {
            (0..n)
                .map(|i| {
                    let (x, y) = ((i % 9) as f32, (i / 9) as f32);
                    Prim::Triangle {
                        p: [Vec3::new(x, y, 0.0), Vec3::new(x + 0.5, y, 0.1), Vec3::new(x, y + 0.5, 0.2)],
                        object: 0,
                        index: i,
                    }
                })
                .collect()
        };
        for (n, most) in [
            (SMALL_TREE as u32, SMALL_TREE_LEAF),
            (SMALL_TREE as u32 + 1, build::MAX_LEAF),
            (2000, build::MAX_LEAF),
        ] {
            let prims = grid(n);
            let bvh = WideBvh::build(&prims);
            let leaves: Vec<Vec<u32>> = bvh
                .children()
                .map(|(_, _, c)| bvh.leaf_prims(c))
                .filter(|l| !l.is_empty())
                .collect();
            let largest = leaves.iter().map(Vec::len).max().unwrap_or(0);
            assert!(largest <= most, "{n} primitives: a leaf of {largest}");
            if most > SMALL_TREE_LEAF {
                assert!(largest > SMALL_TREE_LEAF, "{n} primitives: no leaf above {SMALL_TREE_LEAF}");
            }
            let mut all: Vec<u32> = leaves.concat();
            all.sort_unstable();
            assert_eq!(all, (0..n).collect::<Vec<_>>(), "{n} primitives");
        }
    }

    /// NaN and infinite rays miss and are counted, on every kernel; huge but finite
    /// ones (whose box tests overflow) never index an empty slot.
    #[test]
    fn bad_rays_miss_and_are_counted() {
        let mut prims = Vec::new();
        for i in 0..200 {
            let x = i as f32 * 0.1;
            prims.push(Prim::Triangle {
                p: [Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 0.0, 0.0), Vec3::new(x, 1.0, 0.0)],
                object: 0,
                index: i,
            });
        }
        let mut bvh = WideBvh::build(&prims);
        let good = Ray::new(Vec3::new(0.3, 0.3, 5.0), Vec3::new(0.0, 0.0, -1.0));
        for isa in Isa::all_available() {
            assert!(bvh.set_isa(isa));
            assert!(bvh.intersect(&prims, &good).is_some());
            let before = invalid_rays();
            let nan = f32::NAN;
            let bad = [
                Ray::new(Vec3::new(nan, 0.3, 5.0), Vec3::new(0.0, 0.0, -1.0)),
                Ray::new(Vec3::new(0.3, 0.3, 5.0), Vec3::new(nan, nan, nan)),
                Ray::new(Vec3::new(f32::INFINITY, 0.3, 5.0), Vec3::new(0.0, 0.0, -1.0)),
                Ray::with_range(Vec3::new(0.3, 0.3, 5.0), Vec3::new(0.0, 0.0, -1.0), 0.0, nan),
            ];
            for r in &bad {
                assert!(bvh.intersect(&prims, r).is_none());
                assert!(!bvh.occluded(&prims, r));
                let mut visited = 0;
                bvh.traverse(r, |_, _| {
                    visited += 1;
                    false
                });
                assert_eq!(visited, 0);
            }
            assert!(invalid_rays() - before >= 3 * bad.len() as u64);
            for o in [3e38f32, -3e38, 1e30] {
                for d in [
                    Vec3::new(-1.0, 0.0, 0.0),
                    Vec3::new(1e-30, 1.0, 0.0).normalize(),
                    Vec3::new(0.0, 0.0, 1.0),
                ] {
                    let r = Ray::new(Vec3::new(o, 0.5, 0.0), d);
                    let _ = bvh.intersect(&prims, &r);
                    let _ = bvh.occluded(&prims, &r);
                }
            }
        }
    }
}
