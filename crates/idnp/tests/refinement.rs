//! Refinement (eq. 6) splits exactly the cells named: those holding the infeasible points, at
//! their time index and its successor; the penalty adaptation of the fixed-grid baseline touches
//! exactly their corners.

use std::collections::{BTreeSet, HashMap};

use idnp::idnp::{adapt_penalties, refine};
use idnp::quadtree::QuadGrid;
use idnp::scene::Domain;

fn grids(n: usize) -> Vec<QuadGrid> {
    let d = Domain {
        min: [0.0, 0.0],
        cells: [4, 3],
        cell_size: 1.0,
    };
    vec![QuadGrid::new(d, 3).unwrap(); n]
}

fn leaves(g: &QuadGrid) -> BTreeSet<usize> {
    g.leaves().iter().copied().collect()
}

#[test]
fn refinement_splits_exactly_the_cells_named() {
    let mut g = grids(5);
    let before: Vec<BTreeSet<usize>> = g.iter().map(leaves).collect();
    // An interior point at time index 1 and one on an edge at time index 4 (the last grid).
    let a = [1.3, 2.6];
    let b = [2.0, 0.5];
    let cell_a = g[1].locate(a).unwrap();
    let edge_b: BTreeSet<usize> = g[4].leaves_containing(b).into_iter().collect();
    assert_eq!(edge_b.len(), 2, "a point on an edge lies in two closed cells");
    let split = refine(&mut g, &[(1, a), (4, b), (1, a)], 0.0);
    assert_eq!(
        split,
        1 + 1 + 2,
        "G1 and G2 at a (once, though named twice), both cells at b in G4"
    );
    for (j, grid) in g.iter().enumerate() {
        let gone: BTreeSet<usize> = before[j].difference(&leaves(grid)).copied().collect();
        let expected: BTreeSet<usize> = match j {
            1 | 2 => [cell_a].into(),
            4 => edge_b.clone(),
            _ => BTreeSet::new(),
        };
        assert_eq!(gone, expected, "grid {j}");
        for c in &expected {
            assert_eq!(grid.children(*c).unwrap().len(), 4);
        }
        assert_eq!(grid.leaf_count(), before[j].len() + 3 * expected.len());
    }
    // A radius takes the neighbours within it as well; points outside the domain are ignored.
    let mut g = grids(2);
    let n = refine(&mut g, &[(0, [1.95, 1.5]), (0, [9.0, 9.0])], 0.1);
    assert_eq!(n, 2 * 2, "the cells on both sides of x = 2 in G0 and G1");
}

#[test]
fn penalty_adaptation_touches_exactly_the_corners() {
    let g = grids(3);
    let mut extra = vec![HashMap::new(); g.len()];
    let z = [0.5, 0.5];
    let n = adapt_penalties(&g, &mut extra, &[(1, z)], 0.0, 7.0);
    assert_eq!(n, 8, "four corners in G1 and in G2");
    let corners = g[1].leaf_corners(g[1].locate(z).unwrap()).unwrap();
    for (j, e) in extra.iter().enumerate() {
        for (v, key) in g[j].vertex_keys().iter().enumerate() {
            let expected = if j >= 1 && corners.contains(&v) { 7.0 } else { 0.0 };
            assert_eq!(e.get(key).copied().unwrap_or(0.0), expected, "grid {j} vertex {v}");
        }
    }
    // Keys survive a split: the penalised corners keep their penalty.
    let mut g2 = g[1].clone();
    let key = g2.vertex_keys()[corners[3]];
    g2.split_at(&[z]);
    assert!(g2.vertex_keys().contains(&key));
    assert_eq!(extra[1][&key], 7.0);
}
