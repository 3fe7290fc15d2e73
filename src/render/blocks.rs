//! Film sums kept in blocks of passes and added in one fixed tree, so that a single
//! render, a resumed one and merged shards perform exactly the same floating-point
//! additions and give the same bits.
//!
//! Passes are grouped in blocks of [`BLOCK_PASSES`]; within a block they are added in
//! pass order (by one process, possibly resumed: the unfinished block's sums are
//! saved as they are). Finished blocks are then combined pairwise in a binary tree
//! over block indices: the node of level `l` and index `i` (blocks `[i·2^l, (i+1)·2^l)`)
//! is its left child plus its right child. A render, a shard or a merge keeps the
//! largest nodes its passes complete ([`FilmState::combine`]); the image is the fold
//! of those pieces from left to right. A plain left-to-right fold over blocks would
//! not do: a shard starting at block 5 cannot know the sum of blocks 0–4 it would
//! have to add to. Each node is the same sum whoever computes it, and the pieces of
//! `[0, n)` after combining are the same whatever the split, so the result is too.

use crate::film::Sums;
use std::ops::Range;

/// Passes a block holds. A render of at most this many passes is one block: its sums
/// are the plain pass-order sums of a render without blocks.
pub const BLOCK_PASSES: u32 = 16;

/// The sums of the passes `passes`.
#[derive(Clone, Debug, PartialEq)]
pub struct Piece {
    pub passes: Range<u32>,
    pub sums: Sums,
}

impl Piece {
    fn len(&self) -> u32 {
        self.passes.end - self.passes.start
    }

    /// A tree node: a power-of-two number of whole blocks, aligned to its size.
    fn is_node(&self) -> bool {
        let n = self.len();
        n >= BLOCK_PASSES && n.is_multiple_of(BLOCK_PASSES) && (n / BLOCK_PASSES).is_power_of_two() && self.passes.start.is_multiple_of(n)
    }
}

/// The pieces a render (or shard, or merge) holds, sorted and disjoint.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FilmState {
    pub pieces: Vec<Piece>,
}

impl FilmState {
    /// Adds a piece (a finished block, or an unfinished one at the end) and combines.
    pub fn push(&mut self, piece: Piece) {
        self.pieces.push(piece);
        self.combine();
    }

    /// Sorts the pieces and replaces every pair of sibling nodes by their parent
    /// (left + right), until no two siblings are left.
    pub fn combine(&mut self) {
        self.pieces.sort_by_key(|p| p.passes.start);
        let mut i = 0;
        while i + 1 < self.pieces.len() {
            let (a, b) = (&self.pieces[i], &self.pieces[i + 1]);
            let siblings =
                a.is_node() && b.is_node() && a.len() == b.len() && a.passes.end == b.passes.start && a.passes.start % (2 * a.len()) == 0;
            if siblings {
                let right = self.pieces.remove(i + 1);
                let left = &mut self.pieces[i];
                left.sums.add(&right.sums);
                left.passes.end = right.passes.end;
                // the parent may have a sibling before it
                i = i.saturating_sub(1);
            } else {
                i += 1;
            }
        }
    }

    /// Passes held.
    pub fn passes_done(&self) -> u32 {
        self.pieces.iter().map(Piece::len).sum()
    }

    /// The pass ranges held, adjacent pieces joined.
    pub fn ranges(&self) -> Vec<Range<u32>> {
        let mut out: Vec<Range<u32>> = Vec::new();
        for p in &self.pieces {
            match out.last_mut() {
                Some(last) if last.end == p.passes.start => last.end = p.passes.end,
                _ => out.push(p.passes.clone()),
            }
        }
        out
    }

    /// The pieces' sum, folded from left to right (no addition for a single piece).
    pub fn total(&self) -> Option<Sums> {
        let (first, rest) = self.pieces.split_first()?;
        let mut acc = first.sums.clone();
        for p in rest {
            acc.add(&p.sums);
        }
        Some(acc)
    }

    /// The first overlap between pieces, if any.
    pub fn overlap(&self) -> Option<(Range<u32>, Range<u32>)> {
        let mut sorted: Vec<&Piece> = self.pieces.iter().collect();
        sorted.sort_by_key(|p| p.passes.start);
        sorted
            .windows(2)
            .find(|w| w[0].passes.end > w[1].passes.start)
            .map(|w| (w[0].passes.clone(), w[1].passes.clone()))
    }
}

/// The passes of shard `k` (0-based) of `n` of a render of `total` passes: the k-th of
/// n near-equal runs of whole blocks (empty when there are fewer blocks than shards).
pub fn shard_range(k: u32, n: u32, total: u32) -> Range<u32> {
    let blocks = total.div_ceil(BLOCK_PASSES) as u64;
    let at = |i: u64| ((i * blocks / n as u64) * BLOCK_PASSES as u64).min(total as u64) as u32;
    at(k as u64)..at(k as u64 + 1)
}

/// `0-16,32-40` (pass ranges as the header writes them).
pub fn format_ranges(ranges: &[Range<u32>]) -> String {
    ranges
        .iter()
        .map(|r| format!("{}-{}", r.start, r.end))
        .collect::<Vec<_>>()
        .join(",")
}

/// The inverse of [`format_ranges`].
pub fn parse_ranges(text: &str) -> Option<Vec<Range<u32>>> {
    if text.is_empty() {
        return Some(Vec::new());
    }
    text.split(',')
        .map(|r| {
            let (a, b) = r.split_once('-')?;
            let (a, b) = (a.parse().ok()?, b.parse().ok()?);
            (a < b).then_some(a..b)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn piece(r: Range<u32>, v: f64) -> Piece {
        Piece {
            passes: r,
            sums: Sums {
                sum: vec![[v; 3]],
                weight: vec![1.0],
                splat: None,
            },
        }
    }

    #[test]
    fn any_split_combines_into_the_same_tree() {
        // values whose sums round differently in different orders
        let vals: Vec<f64> = (0..11)
            .map(|i| 1.0 + (i as f64) * 1e-16 + if i % 3 == 0 { 1e16 } else { 0.0 })
            .collect();
        let block = |i: usize| piece(i as u32 * BLOCK_PASSES..(i as u32 + 1) * BLOCK_PASSES, vals[i]);
        let mut single = FilmState::default();
        for i in 0..vals.len() {
            single.push(block(i));
        }
        for split in 1..vals.len() {
            let mut a = FilmState::default();
            let mut b = FilmState::default();
            for i in 0..split {
                a.push(block(i));
            }
            for i in split..vals.len() {
                b.push(block(i));
            }
            a.pieces.extend(b.pieces);
            a.combine();
            assert_eq!(a, single, "split at {split}");
        }
        assert_eq!(single.ranges(), vec![0..11 * BLOCK_PASSES]);
        assert_eq!(single.pieces.len(), 3); // 8 + 2 + 1 blocks
    }

    #[test]
    fn shards_cover_the_blocks_without_overlap() {
        for total in [1, 15, 16, 17, 64, 100, 1000] {
            for n in 1..9 {
                let mut end = 0;
                for k in 0..n {
                    let r = shard_range(k, n, total);
                    assert_eq!(r.start, end);
                    assert!(r.start.is_multiple_of(BLOCK_PASSES));
                    end = r.end;
                }
                assert_eq!(end, total);
            }
        }
        assert_eq!(parse_ranges("0-16,32-40"), Some(vec![0..16, 32..40]));
        assert_eq!(format_ranges(&[0..16, 32..40]), "0-16,32-40");
    }
}
