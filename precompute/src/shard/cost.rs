//! Cutting the rows of `F_k` into shards of about equal cost.
//!
//! A row costs what [`FormFactors::row`](crate::formfactor::FormFactors::row) integrates:
//! per target that is not culled, the closed-form kernel over each part facing the element
//! (clustered patches have many) and one visibility fraction (rays), at the same number of
//! samples for every pair. Counting them costs a few dot products per pair (O(nk), far
//! below the integrals' O(nk·samples) point-to-polygon factors and rays), is the same in every
//! shard (no randomness, no timing), and tracks the real cost where cutting by row count does
//! not: in a box, the rows of a wall see the other walls while half the pairs of a small
//! block's faces are culled. Adaptive visibility refinement near shadow edges is not
//! foreseen; docs/DISTRIBUTED.md reports the balance this model reaches.

use rayon::prelude::*;

use crate::formfactor::FormFactors;
use crate::geometry::Region;
use crate::patches::Mesh;

/// The visibility fraction of a pair (its rays, about 1.8 per sample in the Cornell box),
/// in units of one part's closed-form kernel at every sample. Fitted on the dense sphere
/// (`scripts/shard-balance`, 7 shards, slowest over mean in CPU time): 0 gave 1.68, 3 gave
/// 1.21, 4 gave 1.12, 6 gave 1.16, 16 gave 1.75 (on this shared machine: ±0.05).
const VISIBILITY_COST: u64 = 4;

/// Estimated cost of every row of `F_k`, in file order: 1 (the row's quadrature) + per
/// target that is not culled, its parts that face the element (closed-form kernels) +
/// [`VISIBILITY_COST`] when the scene can occlude (rays).
pub(crate) fn row_costs(mesh: &Mesh, occluded: bool) -> Vec<u64> {
    let targets: Vec<Region> = mesh.patches.iter().map(|p| p.shape.clone()).collect();
    let ray = if occluded { VISIBILITY_COST } else { 0 };
    (0..mesh.n())
        .into_par_iter()
        .map(|s| 1 + FormFactors::row_cost(&mesh.element_at(s).polygon, &targets, ray))
        .collect()
}

/// `count + 1` row boundaries from 0 to `costs.len()`: shard `i` holds the rows
/// `b[i]..b[i + 1]`, each boundary the row where the running cost is nearest to `i/count` of
/// the total (shards may be empty when there are more shards than rows).
pub fn boundaries(costs: &[u64], count: usize) -> Vec<usize> {
    let mut prefix = Vec::with_capacity(costs.len() + 1);
    let mut sum = 0u128;
    prefix.push(0u128);
    for &c in costs {
        sum += u128::from(c);
        prefix.push(sum);
    }
    let mut out = Vec::with_capacity(count + 1);
    out.push(0);
    for i in 1..count {
        let target = sum * i as u128;
        // The first boundary whose running cost reaches i/count of the total (there is one:
        // the last reaches all of it), or the one before when that is nearer.
        let at = prefix.partition_point(|&p| p * (count as u128) < target);
        let after = prefix[at] * count as u128 - target;
        let b = if at > 0 && target - prefix[at - 1] * (count as u128) < after {
            at - 1
        } else {
            at
        };
        out.push(b.clamp(*out.last().expect("one boundary"), costs.len()));
    }
    out.push(costs.len());
    out
}

/// Estimated cost of each shard.
pub fn shard_costs(costs: &[u64], boundaries: &[usize]) -> Vec<u64> {
    boundaries
        .windows(2)
        .map(|w| costs[w[0]..w[1]].iter().sum())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn boundaries_balance_cost_not_count() {
        // Ten cheap rows, then two expensive ones: two shards split the cost, not the rows.
        let costs = [1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 10, 10];
        assert_eq!(boundaries(&costs, 2), vec![0, 11, 12]);
        assert_eq!(boundaries(&costs, 1), vec![0, 12]);
        let even = [5u64; 14];
        assert_eq!(boundaries(&even, 7), vec![0, 2, 4, 6, 8, 10, 12, 14]);
        // More shards than rows: some are empty, every row is in exactly one.
        let b = boundaries(&[3, 3], 5);
        assert_eq!(b.len(), 6);
        assert!(b.windows(2).all(|w| w[0] <= w[1]));
        assert_eq!((b[0], b[5]), (0, 2));
        assert_eq!(shard_costs(&[3, 3], &b).iter().sum::<u64>(), 6);
        assert_eq!(boundaries(&[], 3), vec![0, 0, 0, 0]);
    }
}
