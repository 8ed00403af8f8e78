//! A minimal Foxglove WebSocket client for measuring the live view: connects to
//! `ws://127.0.0.1:PORT`, subscribes to every advertised channel and counts the messages and bytes
//! it receives until the server closes or SECONDS pass.
//!
//! ```text
//! cargo run --release -p sim2d --bin scenario --features live -- scenarios/cylinders.toml --live --rate 0 &
//! cargo run --release -p sim2d --example live_client -- 8765 600
//! ```

use std::net::TcpStream;
use std::time::{Duration, Instant};

use tungstenite::client::IntoClientRequest;
use tungstenite::Message;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let port: u16 = args.next().as_deref().unwrap_or("8765").parse()?;
    let seconds: f64 = args.next().as_deref().unwrap_or("60").parse()?;
    let deadline = Instant::now() + Duration::from_secs_f64(seconds);
    // The server may still be starting: retry the connection for a few seconds.
    let stream = loop {
        match TcpStream::connect(("127.0.0.1", port)) {
            Ok(s) => break s,
            Err(_) if Instant::now() < deadline => {
                std::thread::sleep(Duration::from_millis(5));
            }
            Err(e) => return Err(e.into()),
        }
    };
    stream.set_read_timeout(Some(Duration::from_secs(2)))?;
    let mut request = format!("ws://127.0.0.1:{port}").into_client_request()?;
    request
        .headers_mut()
        .insert("Sec-WebSocket-Protocol", "foxglove.sdk.v1".parse()?);
    let (mut ws, _) = tungstenite::client(request, stream)?;
    let (mut messages, mut bytes, mut next_id) = (0u64, 0u64, 1u64);
    while Instant::now() < deadline {
        match ws.read() {
            Ok(Message::Text(text)) => {
                let v: serde_json::Value = serde_json::from_str(&text)?;
                if v["op"] == "advertise" {
                    let subs: Vec<serde_json::Value> = v["channels"]
                        .as_array()
                        .into_iter()
                        .flatten()
                        .map(|c| {
                            next_id += 1;
                            serde_json::json!({"id": next_id, "channelId": c["id"]})
                        })
                        .collect();
                    let n = subs.len();
                    ws.send(Message::Text(
                        serde_json::json!({"op": "subscribe", "subscriptions": subs})
                            .to_string()
                            .into(),
                    ))?;
                    eprintln!("subscribed to {n} channels");
                }
            }
            Ok(Message::Binary(data)) => {
                messages += 1;
                bytes += data.len() as u64;
            }
            Ok(Message::Close(_)) => break,
            Ok(_) => {}
            Err(tungstenite::Error::Io(e))
                if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => {}
            Err(e) => {
                eprintln!("connection ended: {e}");
                break;
            }
        }
    }
    println!("received {messages} messages, {bytes} bytes");
    Ok(())
}
