//! MCAP logs that Foxglove opens: one file per run, messages JSON-encoded with Foxglove's schemas
//! (schema encoding `jsonschema`, message encoding `json`), all in the `map` frame.
//!
//! | topic | schema | rate |
//! |---|---|---|
//! | `/costmap` | `foxglove.Grid` (field `cost`, `uint8`) | every `costmap_period` (1 s) |
//! | `/lidar` | `foxglove.LaserScan` | with the costmap |
//! | `/robot/pose` | `foxglove.PoseInFrame` | 10 Hz |
//! | `/robot/footprint` | `foxglove.SceneUpdate` (a cube) | 10 Hz |
//! | `/plan` | `foxglove.SceneUpdate` (planned trajectory; A* path or sub-goals as spheres) | every plan |
//! | `/goal` | `foxglove.SceneUpdate` (local goal) | 10 Hz |
//! | `/world` | `foxglove.SceneUpdate` (obstacles, route, route points) | once |
//!
//! The file is written as `<name>.partial` and renamed when the run ends, so a log is whole or
//! absent: a run that fails removes its partial file.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use serde_json::{json, Value};

use crate::error::{Error, Result};
use crate::run::{CycleView, Observer, RunInfo, RunResult};
use crate::scenario::Obstacle;

/// Logging options.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LogOptions {
    /// Seconds between costmap (and lidar) messages; the costmap is the bulk of a log.
    pub costmap_period: f64,
}

impl Default for LogOptions {
    fn default() -> Self {
        Self { costmap_period: 1.0 }
    }
}

const TIME: &str = r#"{"type":"object","properties":{"sec":{"type":"integer","minimum":0},"nsec":{"type":"integer","minimum":0,"maximum":999999999}}}"#;
const VEC3: &str =
    r#"{"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"}}}"#;
const QUAT: &str = r#"{"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"},"w":{"type":"number"}}}"#;
const COLOR: &str = r#"{"type":"object","properties":{"r":{"type":"number"},"g":{"type":"number"},"b":{"type":"number"},"a":{"type":"number"}}}"#;

fn pose_schema() -> String {
    format!(r#"{{"type":"object","properties":{{"position":{VEC3},"orientation":{QUAT}}}}}"#)
}

fn grid_schema() -> String {
    let pose = pose_schema();
    format!(
        r#"{{"title":"foxglove.Grid","description":"A 2D grid of data","type":"object","properties":{{"timestamp":{TIME},"frame_id":{{"type":"string"}},"pose":{pose},"column_count":{{"type":"integer","minimum":0}},"cell_size":{{"type":"object","properties":{{"x":{{"type":"number"}},"y":{{"type":"number"}}}}}},"row_stride":{{"type":"integer","minimum":0}},"cell_stride":{{"type":"integer","minimum":0}},"fields":{{"type":"array","items":{{"type":"object","properties":{{"name":{{"type":"string"}},"offset":{{"type":"integer","minimum":0}},"type":{{"type":"integer"}}}}}}}},"data":{{"type":"string","contentEncoding":"base64"}}}}}}"#
    )
}

fn pose_in_frame_schema() -> String {
    let pose = pose_schema();
    format!(
        r#"{{"title":"foxglove.PoseInFrame","description":"A timestamped pose in a named coordinate frame","type":"object","properties":{{"timestamp":{TIME},"frame_id":{{"type":"string"}},"pose":{pose}}}}}"#
    )
}

fn laser_scan_schema() -> String {
    let pose = pose_schema();
    format!(
        r#"{{"title":"foxglove.LaserScan","description":"A single scan from a planar laser range-finder","type":"object","properties":{{"timestamp":{TIME},"frame_id":{{"type":"string"}},"pose":{pose},"start_angle":{{"type":"number"}},"end_angle":{{"type":"number"}},"ranges":{{"type":"array","items":{{"type":"number"}}}},"intensities":{{"type":"array","items":{{"type":"number"}}}}}}}}"#
    )
}

fn scene_update_schema() -> String {
    let pose = pose_schema();
    let prim = |extra: &str| {
        format!(
            r#"{{"type":"array","items":{{"type":"object","properties":{{"pose":{pose},"color":{COLOR}{extra}}}}}}}"#
        )
    };
    let size = format!(r#","size":{VEC3}"#);
    let cubes = prim(&size);
    let spheres = prim(&size);
    let lines = prim(&format!(
        r#","type":{{"type":"integer"}},"thickness":{{"type":"number"}},"scale_invariant":{{"type":"boolean"}},"points":{{"type":"array","items":{VEC3}}},"colors":{{"type":"array","items":{COLOR}}},"indices":{{"type":"array","items":{{"type":"integer"}}}}"#
    ));
    let empty = r#"{"type":"array","items":{"type":"object"}}"#;
    format!(
        r#"{{"title":"foxglove.SceneUpdate","description":"An update to the entities displayed in a 3D scene","type":"object","properties":{{"deletions":{{"type":"array","items":{{"type":"object","properties":{{"timestamp":{TIME},"type":{{"type":"integer"}},"id":{{"type":"string"}}}}}}}},"entities":{{"type":"array","items":{{"type":"object","properties":{{"timestamp":{TIME},"frame_id":{{"type":"string"}},"id":{{"type":"string"}},"lifetime":{TIME},"frame_locked":{{"type":"boolean"}},"metadata":{empty},"arrows":{empty},"cubes":{cubes},"spheres":{spheres},"cylinders":{empty},"lines":{lines},"triangles":{empty},"texts":{empty},"models":{empty}}}}}}}}}}}"#
    )
}

/// Standard base64 (RFC 4648) with padding.
pub fn base64(data: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(data.len().div_ceil(3) * 4);
    for c in data.chunks(3) {
        let b = [c[0], *c.get(1).unwrap_or(&0), *c.get(2).unwrap_or(&0)];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        out.push(A[(n >> 18) as usize & 63] as char);
        out.push(A[(n >> 12) as usize & 63] as char);
        out.push(if c.len() > 1 {
            A[(n >> 6) as usize & 63] as char
        } else {
            '='
        });
        out.push(if c.len() > 2 { A[n as usize & 63] as char } else { '=' });
    }
    out
}

fn stamp(t: f64) -> Value {
    let ns = (t.max(0.0) * 1e9).round() as u64;
    json!({"sec": ns / 1_000_000_000, "nsec": ns % 1_000_000_000})
}

fn pose(x: f64, y: f64, theta: f64) -> Value {
    json!({"position": {"x": x, "y": y, "z": 0.0},
           "orientation": {"x": 0.0, "y": 0.0, "z": (0.5 * theta).sin(), "w": (0.5 * theta).cos()}})
}

fn color(r: f64, g: f64, b: f64, a: f64) -> Value {
    json!({"r": r, "g": g, "b": b, "a": a})
}

fn point(p: [f64; 2], z: f64) -> Value {
    json!({"x": p[0], "y": p[1], "z": z})
}

/// A scene entity with every primitive list present (Foxglove's JSON reader expects them).
fn entity(t: f64, id: &str, cubes: Vec<Value>, spheres: Vec<Value>, lines: Vec<Value>) -> Value {
    json!({"timestamp": stamp(t), "frame_id": "map", "id": id, "lifetime": {"sec": 0, "nsec": 0},
           "frame_locked": false, "metadata": [], "arrows": [], "cubes": cubes, "spheres": spheres,
           "cylinders": [], "lines": lines, "triangles": [], "texts": [], "models": []})
}

fn line_strip(points: &[[f64; 2]], z: f64, thickness: f64, c: Value, closed: bool) -> Value {
    json!({"type": if closed { 1 } else { 0 }, "pose": pose(0.0, 0.0, 0.0), "thickness": thickness,
           "scale_invariant": false, "points": points.iter().map(|p| point(*p, z)).collect::<Vec<_>>(),
           "color": c, "colors": [], "indices": []})
}

fn sphere(p: [f64; 2], d: f64, c: Value) -> Value {
    json!({"pose": pose(p[0], p[1], 0.0), "size": {"x": d, "y": d, "z": d}, "color": c})
}

/// Writes one run's MCAP log (see the module docs); an [`Observer`].
pub struct McapLogger {
    path: PathBuf,
    partial: PathBuf,
    writer: Option<mcap::Writer<BufWriter<File>>>,
    channels: BTreeMap<&'static str, u16>,
    sequence: u32,
    options: LogOptions,
    next_costmap: f64,
    footprint: [f64; 2],
}

impl McapLogger {
    /// Creates `<path>.partial` and registers the schemas and channels.
    pub fn create(path: impl AsRef<Path>, options: LogOptions) -> Result<Self> {
        let path = path.as_ref().to_path_buf();
        let mut partial = path.clone().into_os_string();
        partial.push(".partial");
        let partial = PathBuf::from(partial);
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| Error::write(dir, e))?;
        }
        let file = File::create(&partial).map_err(|e| Error::write(&partial, e))?;
        let mut writer = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Lz4))
            .profile("")
            .library("ddpkit-sim2d")
            .create(BufWriter::new(file))
            .map_err(|e| Error::write(&partial, e))?;
        let mut channels = BTreeMap::new();
        let schemas = [
            ("foxglove.Grid", grid_schema()),
            ("foxglove.LaserScan", laser_scan_schema()),
            ("foxglove.PoseInFrame", pose_in_frame_schema()),
            ("foxglove.SceneUpdate", scene_update_schema()),
        ];
        let mut schema_ids = BTreeMap::new();
        for (name, text) in &schemas {
            let id = writer
                .add_schema(name, "jsonschema", text.as_bytes())
                .map_err(|e| Error::write(&partial, e))?;
            schema_ids.insert(*name, id);
        }
        for (topic, schema) in [
            ("/costmap", "foxglove.Grid"),
            ("/lidar", "foxglove.LaserScan"),
            ("/robot/pose", "foxglove.PoseInFrame"),
            ("/robot/footprint", "foxglove.SceneUpdate"),
            ("/plan", "foxglove.SceneUpdate"),
            ("/goal", "foxglove.SceneUpdate"),
            ("/world", "foxglove.SceneUpdate"),
        ] {
            let id = writer
                .add_channel(schema_ids[schema], topic, "json", &BTreeMap::new())
                .map_err(|e| Error::write(&partial, e))?;
            channels.insert(topic, id);
        }
        Ok(Self {
            path,
            partial,
            writer: Some(writer),
            channels,
            sequence: 0,
            options,
            next_costmap: 0.0,
            footprint: [0.8, 0.6],
        })
    }

    /// The final path of the log.
    pub fn path(&self) -> &Path {
        &self.path
    }

    fn write(&mut self, topic: &str, t: f64, msg: &Value) -> Result<()> {
        let writer = self
            .writer
            .as_mut()
            .ok_or_else(|| Error::write(&self.path, "log already finished"))?;
        let ns = (t.max(0.0) * 1e9).round() as u64;
        self.sequence += 1;
        let header = mcap::records::MessageHeader {
            channel_id: self.channels[topic],
            sequence: self.sequence,
            log_time: ns,
            publish_time: ns,
        };
        let data = serde_json::to_vec(msg).map_err(|e| Error::write(&self.partial, e))?;
        writer
            .write_to_known_channel(&header, &data)
            .map_err(|e| Error::write(&self.partial, e))
    }

    /// Finishes the file and renames it to its final path.
    pub fn finish(&mut self) -> Result<()> {
        if let Some(mut w) = self.writer.take() {
            w.finish().map_err(|e| Error::write(&self.partial, e))?;
            let mut inner = w.into_inner();
            std::io::Write::flush(&mut inner).map_err(|e| Error::write(&self.partial, e))?;
            drop(inner);
            std::fs::rename(&self.partial, &self.path).map_err(|e| Error::write(&self.path, e))?;
        }
        Ok(())
    }
}

impl Drop for McapLogger {
    fn drop(&mut self) {
        if self.writer.take().is_some() {
            // Not finished: the run failed. Leave no half log behind.
            let _ = std::fs::remove_file(&self.partial);
        }
    }
}

impl Observer for McapLogger {
    fn on_start(&mut self, info: &RunInfo<'_>) -> Result<()> {
        self.footprint = [info.config.robot.length, info.config.robot.width];
        let grey = color(0.35, 0.35, 0.4, 1.0);
        let mut cubes = Vec::new();
        let mut lines = Vec::new();
        let mut spheres = Vec::new();
        for o in &info.scenario.obstacles {
            match o {
                Obstacle::Cylinder { center, radius } => spheres.push(json!({
                    "pose": pose(center[0], center[1], 0.0),
                    "size": {"x": 2.0 * radius, "y": 2.0 * radius, "z": 0.05}, "color": grey.clone()})),
                Obstacle::Box { center, size, yaw } => cubes.push(json!({
                    "pose": pose(center[0], center[1], *yaw),
                    "size": {"x": size[0], "y": size[1], "z": 1.0}, "color": grey.clone()})),
                Obstacle::Polygon { points } => lines.push(line_strip(points, 0.0, 0.08, grey.clone(), true)),
            }
        }
        lines.push(line_strip(
            info.route.points(),
            0.01,
            0.06,
            color(0.2, 0.7, 0.3, 0.8),
            false,
        ));
        for p in info.route.points() {
            spheres.push(sphere(*p, 0.8, color(0.2, 0.8, 0.3, 0.6)));
        }
        let msg = json!({"deletions": [], "entities": [entity(0.0, "world", cubes, spheres, lines)]});
        self.write("/world", 0.0, &msg)?;
        let mut meta = BTreeMap::new();
        meta.insert("scenario".to_string(), info.scenario.name.clone());
        meta.insert("planner".to_string(), info.config.planner.name().to_string());
        meta.insert("direction".to_string(), info.config.direction.name().to_string());
        meta.insert("seed".to_string(), info.config.seed.to_string());
        let writer = self.writer.as_mut().expect("open until finish");
        writer
            .write_metadata(&mcap::records::Metadata {
                name: "run".into(),
                metadata: meta,
            })
            .map_err(|e| Error::write(&self.partial, e))
    }

    fn on_cycle(&mut self, c: &CycleView<'_>) -> Result<()> {
        let t = c.time;
        let [x, y, th] = c.pose;
        self.write(
            "/robot/pose",
            t,
            &json!({"timestamp": stamp(t), "frame_id": "map", "pose": pose(x, y, th)}),
        )?;
        let cube = json!({"pose": pose(x, y, th), "size": {"x": self.footprint[0], "y": self.footprint[1], "z": 0.4},
                          "color": color(0.1, 0.3, 0.9, 0.9)});
        self.write(
            "/robot/footprint",
            t,
            &json!({"deletions": [], "entities": [entity(t, "robot", vec![cube], vec![], vec![])]}),
        )?;
        self.write(
            "/goal",
            t,
            &json!({"deletions": [], "entities": [entity(t, "goal", vec![],
                    vec![sphere(c.goal, 0.4, color(0.1, 0.4, 1.0, 0.9))], vec![])]}),
        )?;
        if let Some(plan) = c.plan {
            let pts: Vec<[f64; 2]> = plan.states.iter().map(|s| [s[0], s[1]]).collect();
            let guide = plan
                .guide
                .iter()
                .map(|g| sphere(*g, 0.25, color(0.1, 0.8, 0.2, 0.9)))
                .collect();
            self.write(
                "/plan",
                t,
                &json!({"deletions": [], "entities": [entity(t, "plan", vec![], guide,
                        vec![line_strip(&pts, 0.05, 0.05, color(0.0, 0.8, 0.2, 1.0), false)])]}),
            )?;
        }
        if c.scanned && t + 1e-9 >= self.next_costmap {
            self.next_costmap = t + self.options.costmap_period;
            let map = c.perception.costmap();
            let g = map.geometry();
            let o = g.origin();
            self.write(
                "/costmap",
                t,
                &json!({"timestamp": stamp(t), "frame_id": "map", "pose": pose(o[0], o[1], 0.0),
                        "column_count": g.width(), "cell_size": {"x": g.resolution(), "y": g.resolution()},
                        "row_stride": g.width(), "cell_stride": 1,
                        "fields": [{"name": "cost", "offset": 0, "type": 1}],
                        "data": base64(map.cells())}),
            )?;
            let s = c.scan;
            let n = s.ranges.len().max(1) as f64;
            self.write(
                "/lidar",
                t,
                &json!({"timestamp": stamp(t), "frame_id": "map", "pose": pose(s.pose[0], s.pose[1], s.pose[2]),
                        "start_angle": 0.0, "end_angle": std::f64::consts::TAU * (n - 1.0) / n,
                        "ranges": s.ranges, "intensities": []}),
            )?;
        }
        Ok(())
    }

    fn on_end(&mut self, _result: &RunResult) -> Result<()> {
        self.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc4648_vectors() {
        for (i, o) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(i.as_bytes()), o);
        }
    }

    #[test]
    fn schemas_are_valid_json() {
        for s in [
            grid_schema(),
            pose_in_frame_schema(),
            laser_scan_schema(),
            scene_update_schema(),
        ] {
            let v: Value = serde_json::from_str(&s).unwrap();
            assert!(v["properties"].is_object());
        }
    }
}
