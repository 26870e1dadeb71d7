//! `GET /`: the inspector page, one static file built into the binary.

use axum::http::header;
use axum::response::IntoResponse;

const PAGE: &str = include_str!("../page/index.html");

pub async fn index() -> impl IntoResponse {
    (
        [
            (header::CONTENT_TYPE, "text/html; charset=utf-8"),
            (header::CACHE_CONTROL, "no-cache"),
        ],
        PAGE,
    )
}
