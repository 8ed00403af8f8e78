//! The live view (feature `live`): a WebSocket client on loopback subscribes to `/tf` and
//! receives the robot's transforms while a run goes; a port in use is an error naming it.
#![cfg(feature = "live")]

use std::net::TcpStream;
use std::sync::Arc;
use std::time::{Duration, Instant};

use prost::Message as _;
use sim2d::batch::{run_batch, BatchOptions, Job};
use sim2d::live::LiveView;
use sim2d::{Route, RunConfig, Scenario};
use tungstenite::client::IntoClientRequest;
use tungstenite::Message;

fn job() -> Job {
    Job {
        scenario: Arc::new(Scenario {
            name: "live".into(),
            description: String::new(),
            route: Route::new(vec![[0.0, 0.0], [18.0, 0.0]]).unwrap(),
            obstacles: vec![],
        }),
        config: RunConfig {
            max_time: 3.0,
            ..RunConfig::default()
        },
        run: 0,
    }
}

#[test]
fn a_client_subscribes_to_tf_and_receives_the_robot() {
    let deadline = Instant::now() + Duration::from_secs(60);
    let view = LiveView::start(0, 4.0).unwrap();
    let port = view.port();
    assert_ne!(port, 0);

    let stream = TcpStream::connect(("127.0.0.1", port)).unwrap();
    stream.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    let mut request = format!("ws://127.0.0.1:{port}").into_client_request().unwrap();
    request
        .headers_mut()
        .insert("Sec-WebSocket-Protocol", "foxglove.sdk.v1".parse().unwrap());
    let (mut ws, _) = tungstenite::client(request, stream).unwrap();

    // The server advertises every channel of the live view; find /tf.
    let mut tf_channel = None;
    while tf_channel.is_none() {
        assert!(Instant::now() < deadline, "no advertisement of /tf");
        if let Message::Text(text) = ws.read().unwrap() {
            let v: serde_json::Value = serde_json::from_str(&text).unwrap();
            if v["op"] == "advertise" {
                for c in v["channels"].as_array().unwrap() {
                    if c["topic"] == "/tf" {
                        assert_eq!(c["encoding"], "protobuf");
                        assert_eq!(c["schemaName"], "foxglove.FrameTransforms");
                        tf_channel = c["id"].as_u64();
                    }
                }
            }
        }
    }
    let sub = serde_json::json!({"op": "subscribe", "subscriptions": [{"id": 7, "channelId": tf_channel}]});
    ws.send(Message::Text(sub.to_string().into())).unwrap();
    // Give the server a moment to register the subscription before the run starts.
    std::thread::sleep(Duration::from_millis(300));

    let link = view.link();
    let started = Instant::now();
    let runner = std::thread::spawn(move || {
        let options = BatchOptions {
            mcap: false,
            png: false,
            progress: false,
            live: Some(link),
            ..BatchOptions::default()
        };
        run_batch(&[job()], &options).unwrap()
    });

    let mut received = Vec::new();
    while received.len() < 5 && Instant::now() < deadline {
        match ws.read() {
            Ok(Message::Binary(data)) => {
                // Message data: opcode 1, subscription id (u32 LE), log time (u64 LE), payload.
                assert_eq!(data[0], 1);
                assert_eq!(u32::from_le_bytes(data[1..5].try_into().unwrap()), 7);
                let tf = foxglove::messages::FrameTransforms::decode(&data[13..]).unwrap();
                received.push(tf);
            }
            Ok(_) => {}
            Err(e) => panic!("no message from the live view: {e}"),
        }
    }
    let results = runner.join().unwrap();
    let wall = started.elapsed();
    assert!(received.len() >= 5, "received {} /tf messages", received.len());
    for tf in &received {
        assert_eq!(tf.transforms[0].parent_frame_id, "map");
        assert_eq!(tf.transforms[0].child_frame_id, "base_link");
        assert_eq!(tf.transforms[1].child_frame_id, "laser");
    }
    // The robot moves along the route (x grows), as the run reports.
    let x = |tf: &foxglove::messages::FrameTransforms| tf.transforms[0].translation.unwrap().x;
    assert!(x(received.last().unwrap()) > x(&received[0]));
    assert!(results[0].time_s >= 2.9);
    // Paced at 4x real time: 3 simulated seconds cannot take less than 0.7 s (a lower bound the
    // pacer's sleeps guarantee, whatever the machine's speed).
    assert!(wall >= Duration::from_millis(700), "{wall:?}");
}

#[test]
fn a_port_in_use_is_named_before_any_run() {
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port();
    let e = LiveView::start(port, 1.0).err().expect("the port is taken").to_string();
    assert!(e.starts_with("live_port") && e.contains(&port.to_string()), "{e}");
    let e = LiveView::start(0, -1.0).err().expect("a negative rate").to_string();
    assert!(e.starts_with("rate"), "{e}");
}
