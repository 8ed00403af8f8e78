//! The shipped Foxglove layout (`foxglove/ddpkit-layout.json`) names only topics and fields the
//! logs have, and its 3D panel follows the robot.

use sim2d::log::{CycleStats, Topics};

#[test]
fn layout_names_logged_topics_and_follows_base_link() {
    let text = std::fs::read_to_string("../../foxglove/ddpkit-layout.json").unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let panels = v["configById"].as_object().unwrap();
    let scene = &panels["3D!ddpkit-scene"];
    assert_eq!(scene["followTf"], "base_link");
    let topics = scene["topics"].as_object().unwrap();
    for t in topics.keys() {
        assert!(Topics::NAMES.contains(&t.as_str()), "{t} is not logged");
    }
    for t in ["/costmap", "/plan", "/world", "/robot/footprint"] {
        assert_eq!(topics[t]["visible"], true, "{t}");
    }
    // The plots read fields of /stats that exist.
    let fields = format!("{:?}", CycleStats::default());
    let mut plotted = Vec::new();
    for (id, p) in panels.iter().filter(|(id, _)| id.starts_with("Plot!")) {
        for path in p["paths"].as_array().unwrap() {
            let value = path["value"].as_str().unwrap();
            let field = value.strip_prefix("/stats.").unwrap_or_else(|| panic!("{id}: {value}"));
            assert!(fields.contains(&format!("{field}:")), "{id}: no field {field}");
            plotted.push(field.to_string());
        }
    }
    assert!(plotted.contains(&"speed".to_string()) && plotted.contains(&"cycle_ms".to_string()));
    assert!(panels.keys().any(|k| k.starts_with("RawMessages!")));
    // Every panel of the mosaic exists.
    fn leaves(v: &serde_json::Value, out: &mut Vec<String>) {
        match v {
            serde_json::Value::String(s) => out.push(s.clone()),
            serde_json::Value::Object(o) => {
                leaves(&o["first"], out);
                leaves(&o["second"], out);
            }
            other => panic!("bad layout node {other}"),
        }
    }
    let mut ids = Vec::new();
    leaves(&v["layout"], &mut ids);
    assert_eq!(ids.len(), panels.len());
    assert!(ids.iter().all(|id| panels.contains_key(id)));
}
