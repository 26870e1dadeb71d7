//! `GET /v1/ws/mavlink?filter=REGEX`: every message whose name the regex finds, as
//! `{"header": {"system_id", "component_id", "sequence"}, "message": {..}}`, as mavlink2rest
//! sends them. A client may send messages the same way as a POST; each gets `Ok(LEN)` or
//! `Err(WHY)` back.
//!
//! Each client reads from the API's broadcast queue at its own pace: one that falls more than
//! the queue behind loses its oldest messages, counted in `/info`'s `ws_dropped`, and nobody
//! else waits for it. A close from either side ends the connection at once.

use std::sync::atomic::Ordering;
use std::sync::Arc;

use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Query, State};
use axum::http::StatusCode;
use axum::response::Response;
use regex::Regex;
use serde_json::json;
use tokio::sync::broadcast::error::RecvError;

use crate::api::{error, send};
use crate::{Incoming, Shared};

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

/// The message's JSON text, made by the first client that wants it.
fn text(shared: &Shared, incoming: &Incoming) -> Option<String> {
    incoming
        .text
        .get_or_init(|| {
            let message = shared.decoder.to_rest(incoming.id, &incoming.payload)?;
            let h = incoming.header;
            let value = json!({
                "header": {"component_id": h.compid, "sequence": h.seq, "system_id": h.sysid},
                "message": message,
            });
            serde_json::to_string_pretty(&value).ok()
        })
        .clone()
}

async fn serve(shared: Arc<Shared>, filter: Regex, mut socket: WebSocket) {
    let mut events = shared.events.subscribe();
    shared.counts.ws_clients.fetch_add(1, Ordering::Relaxed);
    loop {
        tokio::select! {
            event = events.recv() => match event {
                Ok(incoming) => {
                    let Some(name) = shared.decoder.message(incoming.id).map(|m| &m.name.wire)
                    else {
                        continue;
                    };
                    if !filter.is_match(name) {
                        continue;
                    }
                    let Some(text) = text(&shared, &incoming) else { continue };
                    if socket.send(Message::Text(text.into())).await.is_err() {
                        break;
                    }
                }
                Err(RecvError::Lagged(n)) => {
                    shared.counts.ws_dropped.fetch_add(n, Ordering::Relaxed);
                }
                Err(RecvError::Closed) => break,
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
    shared.counts.ws_clients.fetch_sub(1, Ordering::Relaxed);
}
