//! Quadtree grids: splitting keeps the domain covered, counts cells and grid points, and
//! interpolation reproduces bilinear functions.

use idnp::quadtree::QuadGrid;
use idnp::scene::Domain;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn domain() -> Domain {
    Domain {
        min: [-1.0, 2.0],
        cells: [3, 2],
        cell_size: 0.5,
    }
}

/// Leaves are disjoint, lie in the domain and their areas add up to the domain's; every point of
/// the domain is located in a leaf that contains it.
fn assert_covers(grid: &QuadGrid, rng: &mut ChaCha8Rng) {
    let d = *grid.domain();
    let max = d.max();
    let area: f64 = grid.leaves().iter().map(|&l| grid.cell(l).unwrap().size.powi(2)).sum();
    let total = (max[0] - d.min[0]) * (max[1] - d.min[1]);
    assert!((area - total).abs() < 1e-12, "leaf area {area} vs domain {total}");
    for _ in 0..2000 {
        let p = [rng.random_range(d.min[0]..=max[0]), rng.random_range(d.min[1]..=max[1])];
        let id = grid.locate(p).expect("inside the domain");
        assert!(grid.is_leaf(id));
        let c = grid.cell(id).unwrap();
        let (lo, hi) = (c.min(), c.max());
        assert!(p[0] >= lo[0] - 1e-12 && p[0] <= hi[0] + 1e-12 && p[1] >= lo[1] - 1e-12 && p[1] <= hi[1] + 1e-12);
        // No other leaf contains p in its interior.
        let inside = grid
            .leaves()
            .iter()
            .filter(|&&l| {
                let c = grid.cell(l).unwrap();
                let (lo, hi) = (c.min(), c.max());
                p[0] > lo[0] + 1e-12 && p[0] < hi[0] - 1e-12 && p[1] > lo[1] + 1e-12 && p[1] < hi[1] - 1e-12
            })
            .count();
        assert!(inside <= 1);
    }
    assert!(grid.locate([d.min[0] - 1e-9, d.min[1]]).is_none());
    assert!(
        grid.locate([max[0], max[1]]).is_some(),
        "the upper boundary belongs to the domain"
    );
    assert!(grid.locate([f64::NAN, 0.0]).is_none());
}

#[test]
fn split_keeps_coverage_and_counts() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut grid = QuadGrid::new(domain(), 3).unwrap();
    assert_eq!(grid.leaf_count(), 6);
    assert_eq!(grid.vertex_count(), 4 * 3);
    assert_covers(&grid, &mut rng);

    // One split: +3 leaves, +4 cells, +5 grid points (centre and four edge midpoints).
    let c = grid.locate([-0.9, 2.1]).unwrap();
    assert_eq!(grid.split(&[c, c]), 1, "duplicates count once");
    assert_eq!(grid.leaf_count(), 9);
    assert_eq!(grid.cell_count(), 10);
    assert_eq!(grid.vertex_count(), 12 + 5);
    assert!(!grid.is_leaf(c));
    let children = grid.children(c).unwrap();
    for ch in children {
        assert_eq!(grid.cell(ch).unwrap().size, 0.25);
    }
    assert_covers(&grid, &mut rng);

    // Splitting a neighbour re-uses the shared edge midpoint: +4 new grid points only.
    let n = grid.locate([-0.4, 2.1]).unwrap();
    assert_eq!(grid.split(&[n]), 1);
    assert_eq!(grid.vertex_count(), 17 + 4);
    // A non-leaf is not split again.
    assert_eq!(grid.split(&[c]), 0);

    // Random splits down to the deepest level.
    for _ in 0..60 {
        let p = [rng.random_range(-1.0..0.5), rng.random_range(2.0..3.0)];
        let id = grid.locate(p).unwrap();
        let before = (grid.leaf_count(), grid.cell_count());
        let n = grid.split(&[id]);
        if grid.cell(id).unwrap().level < 3 {
            assert_eq!(n, 1);
            assert_eq!(grid.leaf_count(), before.0 + 3);
            assert_eq!(grid.cell_count(), before.1 + 4);
        } else {
            assert_eq!(n, 0, "cells at max_level stay");
        }
    }
    assert!(grid.depth() <= 3);
    assert_covers(&grid, &mut rng);
    // Every grid point is a corner of some leaf, and the corners are grid points.
    let mut used = vec![false; grid.vertex_count()];
    for &l in grid.leaves() {
        let c = grid.cell(l).unwrap();
        let corners = grid.leaf_corners(l).unwrap();
        let (lo, hi) = (c.min(), c.max());
        let expect = [[lo[0], lo[1]], [hi[0], lo[1]], [lo[0], hi[1]], [hi[0], hi[1]]];
        for (v, e) in corners.iter().zip(expect) {
            let p = grid.vertices()[*v];
            assert!((p[0] - e[0]).abs() < 1e-12 && (p[1] - e[1]).abs() < 1e-12);
            used[*v] = true;
        }
    }
    assert!(used.iter().all(|&u| u));
}

#[test]
fn uniform_grid_counts() {
    let g = QuadGrid::uniform(domain(), 2, 4).unwrap();
    assert_eq!(g.leaf_count(), 6 * 16);
    assert_eq!(g.vertex_count(), (3 * 4 + 1) * (2 * 4 + 1));
    assert!(QuadGrid::uniform(domain(), 5, 4).is_err());
    assert!(QuadGrid::new(domain(), 30).is_err());
}

#[test]
fn interpolation_is_exact_for_bilinear_functions() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut grid = QuadGrid::new(domain(), 4).unwrap();
    for _ in 0..20 {
        let p = [rng.random_range(-1.0..0.5), rng.random_range(2.0..3.0)];
        grid.split_at(&[p]);
    }
    // f = a + b x + c y + d x y is reproduced inside every leaf, hanging nodes or not.
    let f = |p: [f64; 2]| 0.3 - 1.2 * p[0] + 0.7 * p[1] + 0.4 * p[0] * p[1];
    let values: Vec<f64> = grid.vertices().iter().map(|&p| f(p)).collect();
    for _ in 0..1000 {
        let p = [rng.random_range(-1.0..0.5), rng.random_range(2.0..3.0)];
        let v = grid.interpolate(&values, p).unwrap();
        assert!((v - f(p)).abs() < 1e-12);
        let (_, w) = grid.weights(p).unwrap();
        assert!((w.iter().map(|x| x.1).sum::<f64>() - 1.0).abs() < 1e-12);
    }
    // At a grid point the weight is one on that point.
    for (i, &p) in grid.vertices().iter().enumerate() {
        assert!((grid.interpolate(&values, p).unwrap() - values[i]).abs() < 1e-12);
    }
    assert!(grid.interpolate(&values, [5.0, 0.0]).is_none());
}

/// Every pair of touching leaves (sharing an edge or a corner) differs by at most `max_diff`
/// levels; checked by brute force over all pairs.
fn max_level_jump(grid: &QuadGrid) -> u8 {
    let tol = 1e-12;
    let cells: Vec<_> = grid.leaves().iter().map(|&l| grid.cell(l).unwrap()).collect();
    let mut worst = 0;
    for a in &cells {
        for b in &cells {
            let (alo, ahi, blo, bhi) = (a.min(), a.max(), b.min(), b.max());
            let touch =
                alo[0] <= bhi[0] + tol && blo[0] <= ahi[0] + tol && alo[1] <= bhi[1] + tol && blo[1] <= ahi[1] + tol;
            if touch {
                worst = worst.max(a.level.abs_diff(b.level));
            }
        }
    }
    worst
}

#[test]
fn balance_grades_the_refinement_and_keeps_coverage() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut grid = QuadGrid::new(domain(), 5).unwrap();
    // Refine towards one point four times: an unbalanced chain of levels 1..4 next to level 0.
    let p = [-0.49, 2.51];
    for _ in 0..4 {
        grid.split_at(&[p]);
    }
    assert_eq!(grid.depth(), 4);
    assert!(max_level_jump(&grid) > 1);
    let before = grid.leaf_count();
    let split = grid.balance();
    assert!(split > 0);
    assert_eq!(grid.leaf_count(), before + 3 * split);
    assert_eq!(max_level_jump(&grid), 1);
    assert_eq!(grid.depth(), 4, "balancing never deepens the grid");
    assert_covers(&grid, &mut rng);
    // Balanced already: nothing to do; a grid refined by one level is balanced.
    assert_eq!(grid.balance(), 0);
    let mut one = QuadGrid::new(domain(), 5).unwrap();
    one.split_at(&[p]);
    assert_eq!(one.balance(), 0);
}
