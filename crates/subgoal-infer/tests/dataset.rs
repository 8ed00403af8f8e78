//! The sub-goal dataset: determinism, the free centre, goals, A* sub-goals, shards on disk and
//! bad input.

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::path::{Path, PathBuf};

use subgoal_infer::dataset::{
    cell_position, geometry, read_manifest, write_dataset, DatasetError, DatasetParams, Generator, Shard, WriteOptions,
    MAP_CELLS, MAP_LEN, START_CELL,
};
use subgoal_infer::grid::{AStar, Costmap, DistanceField, Inflation, INSCRIBED, LETHAL};

/// A fresh directory under the target dir (tests never write outside the build tree).
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("dataset-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .map(|p| {
            (
                p.file_name().unwrap().to_string_lossy().into_owned(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    out.sort();
    out
}

fn opts(samples: u64, seed: u64, shard_size: usize, threads: Option<usize>) -> WriteOptions {
    WriteOptions {
        threads,
        ..WriteOptions::new(samples, seed, shard_size)
    }
}

#[test]
fn same_seed_same_bytes_and_any_thread_count() {
    let a = scratch("det-a");
    let b = scratch("det-b");
    let c = scratch("det-c");
    let d = scratch("det-d");
    write_dataset(&a, &opts(23, 5, 10, Some(1)), &|_| {}).unwrap();
    write_dataset(&b, &opts(23, 5, 10, Some(1)), &|_| {}).unwrap();
    write_dataset(&c, &opts(23, 5, 10, Some(3)), &|_| {}).unwrap();
    write_dataset(&d, &opts(23, 6, 10, Some(2)), &|_| {}).unwrap();
    let (fa, fb, fc, fd) = (files(&a), files(&b), files(&c), files(&d));
    let names: Vec<_> = fa.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        [
            "manifest.json",
            "shard-00000.safetensors",
            "shard-00001.safetensors",
            "shard-00002.safetensors"
        ]
    );
    // (assert!, not assert_eq!: a failure would print megabytes)
    assert!(fa == fb, "same seed, same bytes");
    assert!(fa == fc, "1 and 3 threads, same bytes");
    assert!(fa[1].1 != fd[1].1, "another seed, other samples");
}

#[test]
fn sample_depends_on_seed_and_index_only() {
    let mut g1 = Generator::new(DatasetParams::default()).unwrap();
    let mut g2 = Generator::new(DatasetParams::default()).unwrap();
    let late = g1.sample(9, 17);
    for i in 0..5 {
        g2.sample(9, i);
    }
    assert_eq!(g2.sample(9, 17), late, "history of the generator does not matter");
    assert_ne!(g1.sample(9, 18).costmap, late.costmap);
    assert_ne!(g1.sample(10, 17).costmap, late.costmap);
}

/// Cheapest path cost from the start to every cell: plain Dijkstra with A*'s step costs, an
/// independent reference for the sub-goal paths.
fn dijkstra(map: &Costmap, start: (usize, usize), blocked: u8, cost_weight: f64) -> Vec<f64> {
    let n = MAP_CELLS;
    let mut d = vec![f64::INFINITY; MAP_LEN];
    let mut heap = BinaryHeap::new();
    let s = start.1 * n + start.0;
    d[s] = 0.0;
    heap.push(Reverse((0u64, s)));
    while let Some(Reverse((bits, i))) = heap.pop() {
        let di = f64::from_bits(bits);
        if di > d[i] {
            continue;
        }
        let (x, y) = ((i % n) as i64, (i / n) as i64);
        for dy in -1..=1i64 {
            for dx in -1..=1i64 {
                let (nx, ny) = (x + dx, y + dy);
                if (dx, dy) == (0, 0) || nx < 0 || ny < 0 || nx >= n as i64 || ny >= n as i64 {
                    continue;
                }
                let j = ny as usize * n + nx as usize;
                let c = map.cells()[j];
                if c >= blocked {
                    continue;
                }
                let len = if dx != 0 && dy != 0 {
                    std::f64::consts::SQRT_2
                } else {
                    1.0
                };
                let nd = di + len * (1.0 + cost_weight * c.min(252) as f64 / 252.0);
                if nd < d[j] {
                    d[j] = nd;
                    heap.push(Reverse((nd.to_bits(), j)));
                }
            }
        }
    }
    d
}

#[test]
fn samples_keep_the_contract() {
    let params = DatasetParams::default();
    let mut gen = Generator::new(params.clone()).unwrap();
    let g = geometry();
    let inflation = Inflation::new(
        params.inscribed_radius,
        params.inflation_radius,
        params.cost_scaling,
        0.05,
    )
    .unwrap();
    let mut field = DistanceField::new(g);
    let mut reinflated = Costmap::new(g);
    let mut astar = AStar::new(&g);
    let mut path = Vec::new();
    for i in 0..40 {
        let s = gen.sample(3, i);
        let m = &s.costmap;
        assert_eq!(m.geometry(), &g);
        // Layout: Costmap::cells is row-major, index = iy * 200 + ix.
        assert_eq!(m.get(7, 11), m.cells()[11 * 200 + 7]);
        // The centre is free: no obstacle cell centre within free_radius, the start passable.
        for iy in 0..MAP_CELLS {
            for ix in 0..MAP_CELLS {
                let p = g.cell_to_world(ix, iy);
                if p[0].hypot(p[1]) <= params.free_radius {
                    assert!(
                        m.get(ix, iy) < LETHAL,
                        "sample {i}: obstacle at ({ix}, {iy}) in the free disc"
                    );
                }
            }
        }
        assert!(
            m.get(START_CELL.0, START_CELL.1) < INSCRIBED,
            "sample {i}: start blocked"
        );
        // Costs are the inflation of the obstacle cells with sim2d's parameters.
        field.compute(m, LETHAL).unwrap();
        inflation.apply(&field, &mut reinflated).unwrap();
        assert_eq!(
            reinflated.cells(),
            m.cells(),
            "sample {i}: not the inflation of its obstacles"
        );
        // The goal: within 0.5 m of the border, passable, the end of the path, in the frame.
        let goal = *s.path.last().unwrap();
        let band = 10;
        assert!(
            goal.0 < band || goal.1 < band || goal.0 >= MAP_CELLS - band || goal.1 >= MAP_CELLS - band,
            "sample {i}: goal {goal:?} not near the border"
        );
        assert!(m.get(goal.0, goal.1) < INSCRIBED);
        assert_eq!(s.goal, cell_position(goal));
        let gw = [s.goal[0] as f64, s.goal[1] as f64];
        assert_eq!(g.world_to_cell(gw), Some(goal), "sample {i}: goal frame");
        // The path: A*'s own, optimal (equal to Dijkstra's cost), 8-connected, through free cells.
        assert_eq!(s.path[0], START_CELL);
        let cost = astar.search(m, START_CELL, goal, &params.astar, &mut path).unwrap();
        assert_eq!(path, s.path, "sample {i}: not the A* path");
        let d = dijkstra(m, START_CELL, params.astar.blocked, params.astar.cost_weight);
        let want = d[goal.1 * MAP_CELLS + goal.0];
        assert!(
            (cost - want).abs() < 1e-9 * want,
            "sample {i}: cost {cost} vs Dijkstra {want}"
        );
        for w in s.path.windows(2) {
            let (dx, dy) = (w[0].0.abs_diff(w[1].0), w[0].1.abs_diff(w[1].1));
            assert!(dx <= 1 && dy <= 1 && dx + dy > 0);
            assert!(m.get(w[1].0, w[1].1) < INSCRIBED);
        }
        // Sub-goals: the path cells at steps 30, 50, 70, in metres.
        for (k, &step) in params.subgoal_steps.iter().enumerate() {
            let cell = s.path[step.min(s.path.len() - 1)];
            assert_eq!(s.subgoals[k], cell_position(cell), "sample {i}, sub-goal {k}");
        }
    }
}

#[test]
fn subgoals_clamp_on_short_paths() {
    let params = DatasetParams {
        subgoal_steps: [2, 5, 100_000],
        ..DatasetParams::default()
    };
    let mut gen = Generator::new(params).unwrap();
    for i in 0..5 {
        let s = gen.sample(1, i);
        assert_eq!(s.subgoals[0], cell_position(s.path[2]));
        assert_eq!(s.subgoals[1], cell_position(s.path[5]));
        assert_eq!(s.subgoals[2], s.goal, "past the end: the goal");
    }
}

/// Whether the segment from the centre to `goal` crosses an obstacle cell.
fn blocked_line(m: &Costmap, goal: [f32; 2]) -> bool {
    (0..=400).any(|k| {
        let t = k as f64 / 400.0;
        let p = [t * goal[0] as f64, t * goal[1] as f64];
        m.cost_at(p).is_some_and(|c| c == LETHAL)
    })
}

#[test]
fn traps_block_the_straight_line() {
    let mut gen = Generator::new(DatasetParams::default()).unwrap();
    let (mut traps, mut blocked) = (0, 0);
    let n = 100;
    for i in 0..n {
        let s = gen.sample(11, i);
        if s.trap {
            traps += 1;
            blocked += blocked_line(&s.costmap, s.goal) as usize;
        }
    }
    // 60 % traps by default; most of them across the line to the goal.
    assert!((45..=75).contains(&traps), "{traps} traps in {n}");
    assert!(
        blocked * 10 >= traps * 7,
        "{blocked} of {traps} traps block the straight line"
    );
}

#[test]
fn shards_round_trip() {
    let dir = scratch("round-trip");
    let o = opts(13, 21, 5, Some(2));
    let summary = write_dataset(&dir, &o, &|_| {}).unwrap();
    assert_eq!(summary.samples, 13);
    let manifest = read_manifest(&dir).unwrap();
    assert_eq!((manifest.samples, manifest.seed, manifest.shard_size), (13, 21, 5));
    assert_eq!(manifest.subgoal_steps, vec![30, 50, 70]);
    assert_eq!(
        manifest
            .shards
            .iter()
            .map(|s| (s.first_index, s.samples))
            .collect::<Vec<_>>(),
        vec![(0, 5), (5, 5), (10, 3)]
    );
    let mut gen = Generator::new(DatasetParams::default()).unwrap();
    for (k, entry) in manifest.shards.iter().enumerate() {
        let shard = Shard::read(&manifest.shard_path(k).unwrap()).unwrap();
        assert_eq!(shard.len() as u64, entry.samples);
        assert_eq!((shard.seed, shard.first_index), (21, entry.first_index));
        assert_eq!(shard.metadata["resolution"], "0.05");
        assert_eq!(shard.metadata["map_cells"], "200");
        assert_eq!(shard.metadata["subgoal_steps"], "[30,50,70]");
        for j in 0..shard.len() {
            let s = gen.sample(21, entry.first_index + j as u64);
            assert_eq!(shard.costmap(j).unwrap(), s.costmap.cells());
            assert_eq!(shard.goals[j], s.goal);
            assert_eq!(shard.subgoals[j], s.subgoals);
            assert_eq!(shard.path_lengths[j] as usize, s.path.len());
            assert_eq!(shard.traps[j], s.trap);
        }
    }
    // A smaller dataset in the same directory replaces the larger one whole.
    write_dataset(&dir, &opts(4, 21, 5, Some(1)), &|_| {}).unwrap();
    let names: Vec<_> = files(&dir).into_iter().map(|(n, _)| n).collect();
    assert_eq!(names, ["manifest.json", "shard-00000.safetensors"]);
    assert_eq!(read_manifest(&dir).unwrap().samples, 4);
}

fn field_of(e: DatasetError) -> String {
    e.field()
}

#[test]
fn bad_input_names_the_field() {
    let dir = scratch("bad");
    let e = write_dataset(&dir, &opts(0, 0, 5, None), &|_| {}).unwrap_err();
    assert!(e.to_string().starts_with("samples"), "{e}");
    assert_eq!(field_of(e), "samples");
    let e = write_dataset(&dir, &opts(5, 0, 0, None), &|_| {}).unwrap_err();
    assert_eq!(field_of(e), "shard_size");
    let e = write_dataset(&dir, &opts(5, 0, 5, Some(0)), &|_| {}).unwrap_err();
    assert_eq!(field_of(e), "threads");
    let mut o = opts(5, 0, 5, None);
    o.params.free_radius = 0.1;
    let e = write_dataset(&dir, &o, &|_| {}).unwrap_err();
    assert!(e.to_string().starts_with("free_radius"), "{e}");
    o.params = DatasetParams {
        subgoal_steps: [30, 30, 70],
        ..DatasetParams::default()
    };
    assert_eq!(field_of(write_dataset(&dir, &o, &|_| {}).unwrap_err()), "subgoal_steps");
    // A directory below a regular file cannot be created.
    let file = dir.join("plain-file");
    std::fs::write(&file, b"x").unwrap();
    let e = write_dataset(&file.join("sub"), &opts(2, 0, 5, None), &|_| {}).unwrap_err();
    assert_eq!(field_of(e), "out_dir");
    assert!(std::fs::read_dir(&dir).unwrap().count() == 1, "nothing written");
    // Nothing half-written by the failed runs: no manifest, no shard.
    assert!(read_manifest(&dir).is_err());
}

#[test]
fn corrupt_shards_are_errors_naming_what_is_wrong() {
    let dir = scratch("corrupt");
    write_dataset(&dir, &opts(2, 0, 5, Some(1)), &|_| {}).unwrap();
    let path = dir.join("shard-00000.safetensors");
    let bytes = std::fs::read(&path).unwrap();
    // Truncated: the header no longer matches the data.
    let e = Shard::from_bytes(&bytes[..bytes.len() - 10], &path).unwrap_err();
    assert_eq!(e.field(), "header", "{e}");
    let e = Shard::from_bytes(&bytes[..4], &path).unwrap_err();
    assert_eq!(e.field(), "header", "{e}");
    // A tensor renamed in the header: the reader names the missing one.
    let n = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
    let header = String::from_utf8(bytes[8..8 + n].to_vec()).unwrap();
    let renamed = header.replacen("\"goals\"", "\"gOals\"", 1);
    let mut b2 = bytes.clone();
    b2[8..8 + n].copy_from_slice(renamed.as_bytes());
    let e = Shard::from_bytes(&b2, &path).unwrap_err();
    assert_eq!(e.field(), "goals", "{e}");
    // Another format version.
    let bumped = header.replacen("\"format_version\":\"1\"", "\"format_version\":\"9\"", 1);
    assert_ne!(bumped, header);
    let mut b3 = bytes.clone();
    b3[8..8 + n].copy_from_slice(bumped.as_bytes());
    let e = Shard::from_bytes(&b3, &path).unwrap_err();
    assert_eq!(e.field(), "metadata.format_version", "{e}");
    // A manifest that does not add up.
    let m = std::fs::read_to_string(dir.join("manifest.json")).unwrap();
    std::fs::write(
        dir.join("manifest.json"),
        m.replacen("\"samples\": 2", "\"samples\": 3", 1),
    )
    .unwrap();
    let e = read_manifest(&dir).unwrap_err();
    assert_eq!(e.field(), "shards", "{e}");
    let e = Shard::read(&dir.join("missing.safetensors")).unwrap_err();
    assert_eq!(e.field(), "path", "{e}");
}
