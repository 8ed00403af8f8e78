//! The shortest planar path between two points among circular obstacles, and which side of each
//! obstacle a path passes.
//!
//! The portfolio's planned start ([`crate::Settings::portfolio_plan`]) steers a start round the
//! obstacles on the sides of this path. Local optima of an obstacle problem differ first by the
//! side of each obstacle the path takes (its homotopy class), and the class of the shortest
//! collision-free path of the robot's position is the class of the peers' optimum more often than
//! that of any start that picks its sides on the way in, where those starts miss it: on the
//! benchmark family's misses by more than 5 % of 18 seeds, 14 of 25 (`bench/peers/README.md`,
//! "The planned start").
//!
//! The path is exact for discs: the shortest path among disjoint or overlapping discs is made of
//! segments tangent to them and arcs of their boundaries (the tangent graph of Liu and Arimoto
//! (1992), a visibility graph for curved obstacles), so Dijkstra's algorithm on the tangent
//! points of the start, the goal and every pair of discs, joined by free tangent segments and by
//! free arcs between a disc's neighbouring tangent points, finds it.

use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::f64::consts::PI;

/// A circular obstacle in the plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Disc {
    /// The centre.
    pub center: [f64; 2],
    /// The radius (not negative).
    pub radius: f64,
}

/// A constraint that is a circular obstacle on two state entries
/// ([`crate::Constraint::planar_disc`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanarDisc {
    /// The state indices of the position `(x[indices[0]], x[indices[1]])`.
    pub indices: [usize; 2],
    /// The obstacle on that position.
    pub disc: Disc,
}

/// Where a planned path wraps round one disc: the middle of its arc on the disc's boundary.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// The disc's index in the list given to [`shortest_path`].
    pub disc: usize,
    /// The middle of the arc along the boundary.
    pub point: [f64; 2],
    /// The unit outward normal of the disc there (the side the path passes on).
    pub normal: [f64; 2],
    /// The path's length from the start to `point`.
    pub s: f64,
}

/// A shortest path from [`shortest_path`].
#[derive(Debug, Clone, PartialEq)]
pub struct PlanarPath {
    /// Its length.
    pub length: f64,
    /// Where it wraps round a disc, in order along the path.
    pub contacts: Vec<Contact>,
    /// A polyline through it: its vertices, and its arcs sampled at most every 0.1 rad.
    pub points: Vec<[f64; 2]>,
}

/// The tolerance, relative to the scene's size: a point less than this inside a disc's boundary
/// counts as outside, and a segment that comes no nearer the centre than the radius minus this
/// touches the disc without entering it (tangent segments end on their discs).
const EPS: f64 = 1e-9;
/// The most discs a path is planned among: the tangent graph has `O(n^2)` nodes and its
/// segments are tested against every disc, `O(n^3)` in all.
pub const MAX_DISCS: usize = 32;
/// Arcs are sampled at most this far apart (radians), to test them against other discs and for
/// [`PlanarPath::points`].
const ARC_STEP: f64 = 0.1;

#[derive(Debug, Clone, Copy)]
struct Node {
    p: [f64; 2],
    /// The disc it lies on and its angle there.
    on: Option<(usize, f64)>,
}

#[derive(Debug, Clone, Copy)]
enum Edge {
    Segment,
    /// The arc on `disc` from the first node's angle by `sweep` radians (signed).
    Arc {
        disc: usize,
        sweep: f64,
    },
}

fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

fn norm(a: [f64; 2]) -> f64 {
    a[0].hypot(a[1])
}

fn on_circle(d: &Disc, angle: f64) -> [f64; 2] {
    [
        d.center[0] + d.radius * angle.cos(),
        d.center[1] + d.radius * angle.sin(),
    ]
}

/// Whether `p` lies inside disc `d` by more than `tol`.
fn inside(d: &Disc, p: [f64; 2], tol: f64) -> bool {
    norm(sub(p, d.center)) < d.radius - tol
}

/// The distance from `c` to the segment `a b`.
fn segment_distance(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    let ab = sub(b, a);
    let len2 = ab[0] * ab[0] + ab[1] * ab[1];
    let t = if len2 > 0.0 {
        (((c[0] - a[0]) * ab[0] + (c[1] - a[1]) * ab[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    norm(sub(c, [a[0] + t * ab[0], a[1] + t * ab[1]]))
}

/// The points of the arc of `d` from `from` by `sweep` radians, excluding its start, at most
/// [`ARC_STEP`] apart.
fn arc_points(d: &Disc, from: f64, sweep: f64) -> impl Iterator<Item = [f64; 2]> + '_ {
    let steps = ((sweep.abs() / ARC_STEP).ceil() as usize).max(1);
    (1..=steps).map(move |i| on_circle(d, from + sweep * i as f64 / steps as f64))
}

/// The shortest path from `start` to `goal` that enters no disc, or `None` when the start or the
/// goal lies inside one, the discs close every way between them, a value is not finite, or there
/// are more than [`MAX_DISCS`] discs.
pub fn shortest_path(start: [f64; 2], goal: [f64; 2], discs: &[Disc]) -> Option<PlanarPath> {
    let finite = |p: [f64; 2]| p[0].is_finite() && p[1].is_finite();
    if discs.len() > MAX_DISCS
        || !finite(start)
        || !finite(goal)
        || discs
            .iter()
            .any(|d| !finite(d.center) || !d.radius.is_finite() || d.radius < 0.0)
    {
        return None;
    }
    // The scene's size sets the tolerances.
    let scale = discs
        .iter()
        .map(|d| d.center[0].abs().max(d.center[1].abs()) + d.radius)
        .chain([start, goal].iter().map(|p| p[0].abs().max(p[1].abs())))
        .fold(1.0, f64::max);
    let tol = EPS * scale;
    if discs.iter().any(|d| inside(d, start, tol) || inside(d, goal, tol)) {
        return None;
    }
    let blocked = |a: [f64; 2], b: [f64; 2]| discs.iter().any(|d| segment_distance(a, b, d.center) < d.radius - tol);

    let mut nodes = vec![Node { p: start, on: None }, Node { p: goal, on: None }];
    let mut edges: Vec<Vec<(usize, f64, Edge)>> = vec![Vec::new(), Vec::new()];
    let add_node = |nodes: &mut Vec<Node>, edges: &mut Vec<Vec<(usize, f64, Edge)>>, disc: usize, angle: f64| {
        let p = on_circle(&discs[disc], angle);
        if discs.iter().enumerate().any(|(k, d)| k != disc && inside(d, p, tol)) {
            return None;
        }
        nodes.push(Node {
            p,
            on: Some((disc, angle.rem_euclid(2.0 * PI))),
        });
        edges.push(Vec::new());
        Some(nodes.len() - 1)
    };
    let link = |edges: &mut Vec<Vec<(usize, f64, Edge)>>, nodes: &[Node], a: usize, b: usize| {
        let (pa, pb) = (nodes[a].p, nodes[b].p);
        if !blocked(pa, pb) {
            let len = norm(sub(pb, pa));
            edges[a].push((b, len, Edge::Segment));
            edges[b].push((a, len, Edge::Segment));
        }
    };
    link(&mut edges, &nodes, 0, 1);
    // The tangents from the start and the goal to each disc.
    for end in [0, 1] {
        let p = nodes[end].p;
        for (i, d) in discs.iter().enumerate() {
            let v = sub(p, d.center);
            let dist = norm(v);
            if dist <= d.radius + tol {
                continue;
            }
            let phi = v[1].atan2(v[0]);
            let alpha = (d.radius / dist).clamp(-1.0, 1.0).acos();
            for angle in [phi + alpha, phi - alpha] {
                if let Some(t) = add_node(&mut nodes, &mut edges, i, angle) {
                    link(&mut edges, &nodes, end, t);
                }
            }
        }
    }
    // The tangents common to each pair of discs: outer ones (both on the same side), and inner
    // ones (crossing between them) where the discs are apart.
    for i in 0..discs.len() {
        for j in i + 1..discs.len() {
            let (a, b) = (&discs[i], &discs[j]);
            let v = sub(b.center, a.center);
            let dist = norm(v);
            if dist <= tol {
                continue;
            }
            let phi = v[1].atan2(v[0]);
            let mut pairs = Vec::with_capacity(4);
            if dist > (a.radius - b.radius).abs() {
                let alpha = ((a.radius - b.radius) / dist).clamp(-1.0, 1.0).acos();
                pairs.push((phi + alpha, phi + alpha));
                pairs.push((phi - alpha, phi - alpha));
            }
            if dist > a.radius + b.radius {
                let alpha = ((a.radius + b.radius) / dist).clamp(-1.0, 1.0).acos();
                pairs.push((phi + alpha, phi + alpha + PI));
                pairs.push((phi - alpha, phi - alpha + PI));
            }
            for (ta, tb) in pairs {
                let Some(na) = add_node(&mut nodes, &mut edges, i, ta) else {
                    continue;
                };
                let Some(nb) = add_node(&mut nodes, &mut edges, j, tb) else {
                    continue;
                };
                link(&mut edges, &nodes, na, nb);
            }
        }
    }
    // The arcs between each disc's neighbouring tangent points that stay out of the others.
    for (i, d) in discs.iter().enumerate() {
        let mut on: Vec<(f64, usize)> = (0..nodes.len())
            .filter_map(|k| match nodes[k].on {
                Some((disc, angle)) if disc == i => Some((angle, k)),
                _ => None,
            })
            .collect();
        on.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        for w in 0..on.len() {
            let (a0, k0) = on[w];
            let (a1, k1) = on[(w + 1) % on.len()];
            if k0 == k1 {
                continue;
            }
            let sweep = (a1 - a0).rem_euclid(2.0 * PI);
            let free =
                arc_points(d, a0, sweep).all(|p| !discs.iter().enumerate().any(|(k, o)| k != i && inside(o, p, tol)));
            if free {
                let len = d.radius * sweep;
                edges[k0].push((k1, len, Edge::Arc { disc: i, sweep }));
                edges[k1].push((k0, len, Edge::Arc { disc: i, sweep: -sweep }));
            }
        }
    }

    // Dijkstra from the start (node 0) to the goal (node 1).
    #[derive(PartialEq)]
    struct Entry(f64, usize);
    impl Eq for Entry {}
    impl Ord for Entry {
        fn cmp(&self, other: &Self) -> Ordering {
            other.0.total_cmp(&self.0).then(other.1.cmp(&self.1))
        }
    }
    impl PartialOrd for Entry {
        fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
            Some(self.cmp(other))
        }
    }
    let mut dist = vec![f64::INFINITY; nodes.len()];
    let mut prev: Vec<Option<(usize, Edge)>> = vec![None; nodes.len()];
    let mut heap = BinaryHeap::new();
    dist[0] = 0.0;
    heap.push(Entry(0.0, 0));
    while let Some(Entry(d, k)) = heap.pop() {
        if k == 1 {
            break;
        }
        if d > dist[k] {
            continue;
        }
        for &(next, len, edge) in &edges[k] {
            let nd = d + len;
            if nd < dist[next] {
                dist[next] = nd;
                prev[next] = Some((k, edge));
                heap.push(Entry(nd, next));
            }
        }
    }
    if !dist[1].is_finite() {
        return None;
    }
    let mut chain = vec![(1, Edge::Segment)];
    let mut k = 1;
    while let Some((p, edge)) = prev[k] {
        chain.push((p, edge));
        k = p;
    }
    chain.reverse();
    // `chain[i] = (node, edge from it to the next node)`.
    let mut points = vec![start];
    let mut contacts: Vec<Contact> = Vec::new();
    // The arc being followed: its disc, first angle, sweep so far and length at its start.
    let mut arc: Option<(usize, f64, f64, f64)> = None;
    let mut s = 0.0;
    let close = |arc: Option<(usize, f64, f64, f64)>, contacts: &mut Vec<Contact>| {
        if let Some((disc, from, sweep, s0)) = arc {
            let mid = from + 0.5 * sweep;
            let d = &discs[disc];
            contacts.push(Contact {
                disc,
                point: on_circle(d, mid),
                normal: [mid.cos(), mid.sin()],
                s: s0 + 0.5 * d.radius * sweep.abs(),
            });
        }
    };
    for w in 0..chain.len() - 1 {
        let (a, edge) = chain[w];
        let b = chain[w + 1].0;
        match edge {
            Edge::Segment => {
                // A segment that ends on a disc begins an arc there (of no length if the path
                // leaves along the next segment straight away).
                close(arc.take(), &mut contacts);
                s += norm(sub(nodes[b].p, nodes[a].p));
                points.push(nodes[b].p);
                if let Some((disc, angle)) = nodes[b].on {
                    arc = Some((disc, angle, 0.0, s));
                }
            }
            Edge::Arc { disc, sweep } => {
                let from = nodes[a].on.map_or(0.0, |(_, angle)| angle);
                let d = &discs[disc];
                points.extend(arc_points(d, from, sweep));
                s += d.radius * sweep.abs();
                arc = match arc {
                    Some((k, start_angle, so_far, s0)) if k == disc => Some((k, start_angle, so_far + sweep, s0)),
                    other => {
                        close(other, &mut contacts);
                        Some((disc, from, sweep, s - d.radius * sweep.abs()))
                    }
                };
            }
        }
    }
    close(arc, &mut contacts);
    if let Some(last) = points.last_mut() {
        *last = goal;
    }
    Some(PlanarPath {
        length: dist[1],
        contacts,
        points,
    })
}

/// The angle a path sweeps round `center` (radians, counter-clockwise positive), as the benchmark
/// family's `winding` measures it: paths from the same start to the same end on the two sides
/// of a disc differ by about `2 pi`, and where they pass close to it the sign tells the side.
pub fn winding(points: impl IntoIterator<Item = [f64; 2]>, center: [f64; 2]) -> f64 {
    let mut total = 0.0;
    let mut last: Option<f64> = None;
    for p in points {
        let angle = (p[1] - center[1]).atan2(p[0] - center[0]);
        if let Some(l) = last {
            let mut d = angle - l;
            if d > PI {
                d -= 2.0 * PI;
            } else if d < -PI {
                d += 2.0 * PI;
            }
            total += d;
        }
        last = Some(angle);
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    fn disc(x: f64, y: f64, r: f64) -> Disc {
        Disc {
            center: [x, y],
            radius: r,
        }
    }

    /// Round one unit disc from (-2, 0) to (2, 0): two tangents of length sqrt(3) and an arc of
    /// pi / 3 (each tangent point at 60 degrees from the axis), on either side; the path here
    /// takes the first found, and its contact is at the top or the bottom of the disc.
    #[test]
    fn one_disc_gives_the_closed_form_length() {
        let p = shortest_path([-2.0, 0.0], [2.0, 0.0], &[disc(0.0, 0.0, 1.0)]).unwrap();
        let exact = 2.0 * 3f64.sqrt() + PI / 3.0;
        assert!((p.length - exact).abs() < 1e-12, "{} against {exact}", p.length);
        assert_eq!(p.contacts.len(), 1);
        let c = p.contacts[0];
        assert!(
            (c.point[0]).abs() < 1e-12 && (c.point[1].abs() - 1.0).abs() < 1e-12,
            "{c:?}"
        );
        assert!((c.s - exact / 2.0).abs() < 1e-12);
        // The polyline's length is the path's, up to the arc's chords.
        let poly: f64 = p.points.windows(2).map(|w| norm(sub(w[1], w[0]))).sum();
        assert!(poly <= p.length + 1e-12 && poly > p.length - 1e-3, "{poly}");
        // It sweeps about pi round the centre, on the contact's side.
        let w = winding(p.points.iter().copied(), [0.0, 0.0]);
        assert!(
            (w.abs() - PI).abs() < 1e-9 && (w < 0.0) == (c.normal[1] > 0.0),
            "{w} {c:?}"
        );
    }

    /// An obstacle off the straight line changes nothing: the path is the segment.
    #[test]
    fn a_free_line_is_the_path() {
        let p = shortest_path([0.0, 0.0], [3.0, 4.0], &[disc(3.0, 0.0, 1.0)]).unwrap();
        assert_eq!(p.length, 5.0);
        assert!(p.contacts.is_empty());
        assert_eq!(p.points, vec![[0.0, 0.0], [3.0, 4.0]]);
    }

    /// A small disc across the line from above and a large one from below, overlapping: the
    /// path goes over the small one's top (0.65) rather than under the large one's bottom
    /// (-1.1), touches only the small one, and has the closed-form length of two tangents and
    /// an arc of it (mirror images of each other across the y axis).
    #[test]
    fn the_shorter_side_of_a_pair_is_taken() {
        let discs = [disc(0.0, 0.35, 0.3), disc(0.0, -0.5, 0.6)];
        let p = shortest_path([-3.0, 0.0], [3.0, 0.0], &discs).unwrap();
        assert_eq!(p.contacts.iter().map(|c| c.disc).collect::<Vec<_>>(), vec![0], "{p:?}");
        assert!(p.contacts[0].normal[1] > 0.99, "{p:?}");
        let (r, d) = (0.3, 3f64.hypot(0.35));
        let to_start = (-0.35f64).atan2(-3.0);
        let alpha = (r / d).acos();
        // The upper tangent point from the start, at an angle in (pi / 2, pi).
        let theta = [to_start + alpha, to_start - alpha]
            .into_iter()
            .map(|a| a.rem_euclid(2.0 * PI))
            .max_by(|a, b| a.sin().total_cmp(&b.sin()))
            .unwrap();
        let exact = 2.0 * (d * d - r * r).sqrt() + r * (2.0 * theta - PI);
        assert!((p.length - exact).abs() < 1e-9, "{} against {exact}", p.length);
    }

    /// Two discs that overlap, across the line: the path goes round the pair as one (over both
    /// or under both), with an arc on each disc and no step into the overlap.
    #[test]
    fn overlapping_discs_are_passed_as_one() {
        let discs = [disc(0.0, 0.5, 0.7), disc(0.0, -0.5, 0.7)];
        let p = shortest_path([-3.0, 0.0], [3.0, 0.0], &discs).unwrap();
        assert_eq!(p.contacts.len(), 1, "{p:?}");
        for q in &p.points {
            for d in &discs {
                assert!(norm(sub(*q, d.center)) >= d.radius - 1e-9, "{q:?} inside {d:?}");
            }
        }
        // Round the top of the upper disc: symmetric, so its contact is straight above it.
        let c = p.contacts[0];
        assert!(
            c.normal[0].abs() < 1e-9 && (c.normal[1].abs() - 1.0).abs() < 1e-9,
            "{c:?}"
        );
    }

    /// No way through: the start inside a disc, or walled in by a ring of overlapping discs.
    #[test]
    fn no_path_where_none_exists() {
        assert!(shortest_path([0.0, 0.0], [3.0, 0.0], &[disc(0.0, 0.0, 1.0)]).is_none());
        let ring: Vec<Disc> = (0..12)
            .map(|k| {
                let a = k as f64 * PI / 6.0;
                disc(2.0 * a.cos(), 2.0 * a.sin(), 0.7)
            })
            .collect();
        assert!(shortest_path([0.0, 0.0], [5.0, 0.0], &ring).is_none());
        assert!(shortest_path([0.0, f64::NAN], [5.0, 0.0], &[]).is_none());
        assert!(shortest_path([0.0, 0.0], [5.0, 0.0], &[disc(1.0, 1.0, -1.0)]).is_none());
    }

    /// Against a fine grid search on random scenes: the tangent graph's path is never longer
    /// than the grid's (which is a feasible path up to its cell), and within its resolution.
    #[test]
    fn random_scenes_agree_with_a_grid_search() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut rand = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut compared = 0;
        for _ in 0..20 {
            let discs: Vec<Disc> = (0..4)
                .map(|_| disc(4.0 * rand() - 0.5, 3.0 * rand() - 1.5, 0.2 + 0.5 * rand()))
                .collect();
            let (start, goal) = ([-1.0, 0.0], [4.0, 0.2]);
            let Some(p) = shortest_path(start, goal, &discs) else {
                continue;
            };
            // The path stays out of every disc.
            for q in &p.points {
                for d in &discs {
                    assert!(norm(sub(*q, d.center)) >= d.radius - 1e-9);
                }
            }
            if let Some(g) = grid_length(start, goal, &discs, 0.02) {
                assert!(p.length <= g + 1e-9, "{} against the grid's {g}", p.length);
                assert!(p.length >= g * 0.96, "{} against the grid's {g}", p.length);
                compared += 1;
            }
        }
        assert!(compared >= 10, "{compared}");
    }

    /// Dijkstra on a grid of cell `h` with 16 neighbours (moves to cells out of every disc).
    fn grid_length(start: [f64; 2], goal: [f64; 2], discs: &[Disc], h: f64) -> Option<f64> {
        let (lo, hi) = ([-3.0, -4.0], [6.0, 4.0]);
        let nx = ((hi[0] - lo[0]) / h) as usize + 1;
        let ny = ((hi[1] - lo[1]) / h) as usize + 1;
        let at = |i: usize, j: usize| [lo[0] + i as f64 * h, lo[1] + j as f64 * h];
        let free = |p: [f64; 2]| discs.iter().all(|d| norm(sub(p, d.center)) > d.radius);
        let cell = |p: [f64; 2]| {
            (
                ((p[0] - lo[0]) / h).round() as usize,
                ((p[1] - lo[1]) / h).round() as usize,
            )
        };
        let (s, g) = (cell(start), cell(goal));
        let mut dist = vec![f64::INFINITY; nx * ny];
        let mut heap = BinaryHeap::new();
        #[derive(PartialEq)]
        struct E(f64, usize);
        impl Eq for E {}
        impl Ord for E {
            fn cmp(&self, o: &Self) -> Ordering {
                o.0.total_cmp(&self.0)
            }
        }
        impl PartialOrd for E {
            fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
                Some(self.cmp(o))
            }
        }
        dist[s.0 * ny + s.1] = 0.0;
        heap.push(E(0.0, s.0 * ny + s.1));
        let moves: Vec<(i64, i64)> = (-2i64..=2)
            .flat_map(|a| (-2i64..=2).map(move |b| (a, b)))
            .filter(|&(a, b)| (a, b) != (0, 0) && (a.abs() + b.abs() <= 2 || a.abs() + b.abs() == 3))
            .collect();
        while let Some(E(d, k)) = heap.pop() {
            if d > dist[k] {
                continue;
            }
            let (i, j) = ((k / ny) as i64, (k % ny) as i64);
            for &(a, b) in &moves {
                let (ni, nj) = (i + a, j + b);
                if ni < 0 || nj < 0 || ni >= nx as i64 || nj >= ny as i64 {
                    continue;
                }
                let (ni, nj) = (ni as usize, nj as usize);
                // The move's midpoint too, so that no move cuts a disc's edge.
                let (p, q) = (at(ni, nj), at(i as usize, j as usize));
                if !free(p) || !free([(p[0] + q[0]) / 2.0, (p[1] + q[1]) / 2.0]) {
                    continue;
                }
                let nd = d + h * ((a * a + b * b) as f64).sqrt();
                if nd < dist[ni * ny + nj] {
                    dist[ni * ny + nj] = nd;
                    heap.push(E(nd, ni * ny + nj));
                }
            }
        }
        let d = dist[g.0 * ny + g.1];
        d.is_finite().then_some(d)
    }
}
