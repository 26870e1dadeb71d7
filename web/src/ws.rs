//! `GET /v1/ws/mavlink?filter=REGEX`: every message whose name the regex finds, as
//! `{"header": {"system_id", "component_id", "sequence"}, "message": {..}}`, as mavlink2rest
//! sends them. A client may send messages the same way as a POST; each gets `Ok(LEN)` or
//! `Err(WHY)` back.
//!
//! Each client has a queue of its own, filled as messages come (only those its filter takes): a
//! client that does not keep up loses the messages its full queue cannot take, counted in
//! `/info`'s `ws_dropped` at once, and nobody else waits for it. A close from either side ends
//! the connection at once.

use std::sync::atomic::Ordering;
use std::sync::Arc;

use axum::extract::ws::{Message, Utf8Bytes, WebSocket, WebSocketUpgrade};
use axum::extract::{Query, State};
use axum::http::StatusCode;
use axum::response::Response;
use ferrolink_runtime::mavlink::Header;
use futures_util::SinkExt;
use regex::Regex;
use serde_json::json;
use tokio::sync::mpsc;

use crate::api::{error, send};
use crate::{lock, Incoming, Shared, CLIENT_QUEUE};

/// A WebSocket client, as the fan-out sees it.
pub struct Client {
    filter: Regex,
    queue: mpsc::Sender<Arc<Incoming>>,
}

/// Hands a message to every client whose filter takes it; a full queue drops it (counted), a
/// client gone is forgotten.
pub(crate) fn fan_out(shared: &Shared, header: Header, id: u32, payload: &[u8]) {
    let mut clients = lock(&shared.clients);
    if clients.is_empty() {
        return;
    }
    let Some(name) = shared.decoder.message(id).map(|m| &m.name.wire) else {
        return;
    };
    let mut incoming: Option<Arc<Incoming>> = None;
    clients.retain(|client| {
        if !client.filter.is_match(name) {
            return !client.queue.is_closed();
        }
        let message = incoming
            .get_or_insert_with(|| {
                Arc::new(Incoming {
                    header,
                    id,
                    payload: payload.to_vec(),
                    text: std::sync::OnceLock::new(),
                })
            })
            .clone();
        match client.queue.try_send(message) {
            Ok(()) => true,
            Err(mpsc::error::TrySendError::Full(_)) => {
                shared.counts.ws_dropped.fetch_add(1, Ordering::Relaxed);
                true
            }
            Err(mpsc::error::TrySendError::Closed(_)) => false,
        }
    });
}

/// How long a client's first waiting message waits for others to go out with it: a bound on
/// the latency a WebSocket adds, and what keeps its writes (and wake-ups) few at high rates.
const COALESCE: std::time::Duration = std::time::Duration::from_millis(20);

#[derive(serde::Deserialize)]
pub struct Filter {
    filter: Option<String>,
}

pub async fn upgrade(
    State(shared): State<Arc<Shared>>,
    Query(q): Query<Filter>,
    ws: WebSocketUpgrade,
) -> Response {
    let filter = match Regex::new(q.filter.as_deref().unwrap_or(".*")) {
        Ok(filter) => filter,
        Err(e) => return error(StatusCode::BAD_REQUEST, format!("filter: {e}")),
    };
    ws.on_upgrade(move |socket| serve(shared, filter, socket))
}

/// The message's JSON text, made by the first client that wants it and shared by the others.
fn text(shared: &Shared, incoming: &Incoming) -> Option<Utf8Bytes> {
    incoming
        .text
        .get_or_init(|| {
            let message = shared.decoder.to_rest(incoming.id, &incoming.payload)?;
            let h = incoming.header;
            let value = json!({
                "header": {"component_id": h.compid, "sequence": h.seq, "system_id": h.sysid},
                "message": message,
            });
            serde_json::to_string_pretty(&value)
                .ok()
                .map(Utf8Bytes::from)
        })
        .clone()
}

async fn serve(shared: Arc<Shared>, filter: Regex, mut socket: WebSocket) {
    let (queue, mut messages) = mpsc::channel(CLIENT_QUEUE);
    lock(&shared.clients).push(Client { filter, queue });
    shared.counts.ws_clients.fetch_add(1, Ordering::Relaxed);
    loop {
        tokio::select! {
            incoming = messages.recv() => match incoming {
                Some(first) => {
                    // What else comes within a moment goes out with it, in one write.
                    tokio::time::sleep(COALESCE).await;
                    let mut batch = vec![first];
                    while let Ok(next) = messages.try_recv() {
                        batch.push(next);
                    }
                    let mut sent = true;
                    for incoming in &batch {
                        if let Some(text) = text(&shared, incoming) {
                            sent &= socket.feed(Message::Text(text)).await.is_ok();
                        }
                    }
                    if !sent || socket.flush().await.is_err() {
                        break;
                    }
                }
                None => break,
            },
            received = socket.recv() => match received {
                Some(Ok(Message::Text(body))) => {
                    let reply = match send(&shared, body.as_bytes()) {
                        Ok(n) => format!("Ok({n})"),
                        Err(why) => format!("Err({why})"),
                    };
                    if socket.send(Message::Text(reply.into())).await.is_err() {
                        break;
                    }
                }
                Some(Ok(Message::Close(_))) | None | Some(Err(_)) => break,
                // Pings are answered by the WebSocket layer; binary frames mean nothing here.
                Some(Ok(_)) => {}
            },
        }
    }
    // Its queue closes with `messages`: the next fan-out forgets it.
    drop(messages);
    shared.counts.ws_clients.fetch_sub(1, Ordering::Relaxed);
}
