//! The REST routes.

use std::sync::atomic::Ordering;
use std::sync::Arc;

use axum::body::Bytes;
use axum::extract::{DefaultBodyLimit, Path, Query, State};
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use serde_json::{json, Value as Json};

use crate::{lock, Shared, MAX_BODY};

/// Every route, with and without `/v1`.
pub fn router(shared: Arc<Shared>) -> axum::Router {
    let v1 = axum::Router::new()
        .route("/mavlink", get(tree).post(post))
        .route("/mavlink/", get(tree))
        .route("/mavlink/{*path}", get(subtree))
        .route("/helper/mavlink", get(helper))
        .route("/ws/mavlink", get(crate::ws::upgrade));
    axum::Router::new()
        .route("/", get(crate::page::index))
        .route("/info", get(info))
        .route("/v1/router", get(router_status))
        .nest("/v1", v1.clone())
        .merge(v1)
        .layer(DefaultBodyLimit::max(MAX_BODY))
        .with_state(shared)
}

/// Pretty JSON, as mavlink2rest answers.
pub fn pretty(status: StatusCode, value: &Json) -> Response {
    let body = serde_json::to_string_pretty(value).unwrap_or_default();
    (status, [(header::CONTENT_TYPE, "application/json")], body).into_response()
}

/// A JSON error: `{"error": why}`.
pub fn error(status: StatusCode, why: impl Into<String>) -> Response {
    pretty(status, &json!({ "error": why.into() }))
}

async fn tree(State(shared): State<Arc<Shared>>) -> Response {
    lookup(&shared, "")
}

async fn subtree(State(shared): State<Arc<Shared>>, Path(path): Path<String>) -> Response {
    lookup(&shared, &path)
}

fn lookup(shared: &Shared, path: &str) -> Response {
    let found = lock(&shared.store).text(&shared.decoder, path);
    match found {
        Ok(text) => (
            StatusCode::OK,
            [(header::CONTENT_TYPE, "application/json")],
            text,
        )
            .into_response(),
        Err(why) => error(StatusCode::NOT_FOUND, why),
    }
}

/// What a POST, or a WebSocket client's text, sends: mavlink2rest's form.
pub fn send(shared: &Shared, body: &[u8]) -> Result<usize, String> {
    let value: Json = serde_json::from_slice(body).map_err(|e| format!("not JSON: {e}"))?;
    let message = value
        .get("message")
        .ok_or("expected {\"header\": {..}, \"message\": {\"type\": NAME, ..}}")?;
    let header = value.get("header");
    let id = |key: &str, default: u8| match header.and_then(|h| h.get(key)) {
        None => Ok(default),
        Some(v) => v
            .as_u64()
            .and_then(|v| u8::try_from(v).ok())
            .ok_or_else(|| format!("header.{key} must be 0 to 255")),
    };
    let (sysid, compid) = (id("system_id", 255)?, id("component_id", 0)?);
    let (msg_id, payload) = shared.decoder.from_rest(message)?;
    shared.send(sysid, compid, msg_id, &payload)
}

async fn post(State(shared): State<Arc<Shared>>, body: Bytes) -> Response {
    match send(&shared, &body) {
        Ok(_) => StatusCode::OK.into_response(),
        Err(why) => error(StatusCode::BAD_REQUEST, why),
    }
}

#[derive(serde::Deserialize)]
struct Name {
    name: Option<String>,
}

async fn helper(State(shared): State<Arc<Shared>>, Query(q): Query<Name>) -> Response {
    let Some(name) = q.name else {
        return error(StatusCode::BAD_REQUEST, "give the message: ?name=NAME");
    };
    match shared.decoder.rest_template(&name) {
        Some(message) => pretty(
            StatusCode::OK,
            &json!({
                "header": {"system_id": 255, "component_id": 0, "sequence": 0},
                "message": message,
            }),
        ),
        None => error(
            StatusCode::NOT_FOUND,
            format!("no message {name:?} in the dialect"),
        ),
    }
}

async fn info(State(shared): State<Arc<Shared>>) -> Response {
    let c = &shared.counts;
    let body = json!({
        "version": 0,
        "service": {
            "name": "ferrolink",
            "version": env!("CARGO_PKG_VERSION"),
            "sha": "",
            "build_date": "",
            "authors": "the Ferrolink developers",
        },
        "ferrolink": {
            "started": humantime::format_rfc3339_seconds(shared.started).to_string(),
            "frames": c.frames.load(Ordering::Relaxed),
            "dropped": c.dropped.load(Ordering::Relaxed),
            "posted": c.posted.load(Ordering::Relaxed),
            "ws_clients": c.ws_clients.load(Ordering::Relaxed),
            "ws_dropped": c.ws_dropped.load(Ordering::Relaxed),
            "untracked": lock(&shared.store).refused,
        },
    });
    (
        [(header::CONTENT_TYPE, "application/json")],
        body.to_string(),
    )
        .into_response()
}

/// The router's links and the systems behind them (for the inspector).
async fn router_status(State(shared): State<Arc<Shared>>) -> Response {
    pretty(StatusCode::OK, &(shared.status)())
}
