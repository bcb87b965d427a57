//! The page's files, embedded in the binary (no build step, no CDN): the only paths the
//! server answers besides its API.

/// An embedded file.
pub struct Asset {
    pub content_type: &'static str,
    pub body: &'static [u8],
}

const INDEX: Asset = Asset {
    content_type: "text/html; charset=utf-8",
    body: include_bytes!("assets/index.html"),
};
const APP: Asset = Asset {
    content_type: "text/javascript; charset=utf-8",
    body: include_bytes!("assets/app.js"),
};
const DRAW: Asset = Asset {
    content_type: "text/javascript; charset=utf-8",
    body: include_bytes!("assets/draw.js"),
};
const STYLE: Asset = Asset {
    content_type: "text/css; charset=utf-8",
    body: include_bytes!("assets/style.css"),
};

/// The asset served at `path` (exactly; nothing else maps to a file).
pub fn find(path: &str) -> Option<&'static Asset> {
    match path {
        "/" | "/index.html" => Some(&INDEX),
        "/app.js" => Some(&APP),
        "/draw.js" => Some(&DRAW),
        "/style.css" => Some(&STYLE),
        _ => None,
    }
}
