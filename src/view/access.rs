//! Who the viewer's server answers (docs/view.md, "Access"), as Jupyter's server decides it:
//!
//! - **Token**: a random token per run (32 bytes from the operating system, as hex). The
//!   printed URL carries it (`/?token=...`); the page's first visit with it sets a cookie
//!   (`HttpOnly`, `SameSite=Strict`) that the page's own requests and WebSocket then carry;
//!   scripts send `Authorization: token TOKEN` (or `?token=`). Compared in constant time.
//! - **Host**: only requests whose `Host` names this server by an address that cannot be
//!   rebound: `localhost`, a loopback address (`127.0.0.1`, `[::1]`) or the `--bind` address
//!   (any address, when bound to all of them). A page of another name that resolves to
//!   127.0.0.1 (DNS rebinding) sends its own name and is refused. The port is not checked:
//!   through `ssh -L 9000:127.0.0.1:8765` the browser names port 9000.
//! - **Origin**: a WebSocket upgrade or a request that changes something (any method but
//!   GET and HEAD) from a page of another origin (`Origin` not `http://` + `Host`) is
//!   refused. Clients that send no `Origin` (curl, scripts) are not browsers' pages.
//! - **Content type**: a POST must say `application/json` (`application/toml` for
//!   `/api/path`), which no cross-origin form or `text/plain` request can send without the
//!   browser first asking the server, which never allows it.
//!
//! Each refusal is one line: 403 for host, token and origin, 415 for the content type.

use super::api::Reply;
use std::net::{IpAddr, SocketAddr};

/// The parts of a request that decide whether it is answered.
#[derive(Clone, Debug, Default)]
pub struct RequestHead<'a> {
    pub method: &'a str,
    /// The request target: path and query.
    pub url: &'a str,
    pub host: Option<&'a str>,
    pub origin: Option<&'a str>,
    pub authorization: Option<&'a str>,
    /// Every `Cookie` header's value.
    pub cookies: Vec<&'a str>,
    pub content_type: Option<&'a str>,
    /// A WebSocket upgrade.
    pub websocket: bool,
}

/// A request let through: its target without the token, and the `Set-Cookie` header value
/// to send when the token came in the query of a GET (the page's first visit).
#[derive(Clone, Debug, PartialEq)]
pub struct Granted {
    pub url: String,
    pub set_cookie: Option<String>,
}

/// The server's token and the addresses it answers to.
pub struct Access {
    token: String,
    cookie_name: String,
    bound: SocketAddr,
}

/// Bytes of randomness in a token (64 hex digits).
const TOKEN_BYTES: usize = 32;

impl Access {
    /// A fresh random token for a server bound to `bound`.
    pub fn new(bound: SocketAddr) -> Result<Access, String> {
        use rand::TryRngCore;
        let mut bytes = [0u8; TOKEN_BYTES];
        rand::rngs::OsRng
            .try_fill_bytes(&mut bytes)
            .map_err(|e| format!("the operating system's random numbers: {e}"))?;
        let token = bytes.iter().map(|b| format!("{b:02x}")).collect();
        Ok(Access::with_token(bound, token))
    }

    /// A server bound to `bound` with a given token (tests).
    pub fn with_token(bound: SocketAddr, token: String) -> Access {
        Access {
            token,
            // Cookies are not kept per port: two servers on one machine need two names.
            cookie_name: format!("femto_view_{}", bound.port()),
            bound,
        }
    }

    pub fn token(&self) -> &str {
        &self.token
    }

    /// The URL to open: the page with the token (`http://127.0.0.1:8765/?token=...`).
    pub fn url(&self) -> String {
        format!("http://{}/?token={}", self.bound, self.token)
    }

    /// Whether `request` is answered: the target to answer (the token taken out of its
    /// query) or the refusal.
    pub fn check(&self, request: &RequestHead) -> Result<Granted, Reply> {
        let Some(host) = request.host.map(str::trim) else {
            return Err(Reply::error(
                403,
                "no Host header: femto view answers requests that name it",
            ));
        };
        if !self.host_allowed(host) {
            return Err(Reply::error(
                403,
                format!(
                    "Host '{}' is not this server: femto view answers localhost, 127.0.0.1, \
                     [::1] or its --bind address (open the URL it printed)",
                    printable(host)
                ),
            ));
        }
        let (path, query) = request.url.split_once('?').unwrap_or((request.url, ""));
        let mut query_token = None;
        let rest: Vec<&str> = query
            .split('&')
            .filter(|p| !p.is_empty())
            .filter(|p| match p.strip_prefix("token=") {
                Some(t) => {
                    query_token = Some(t);
                    false
                }
                None => true,
            })
            .collect();
        let header_token = request.authorization.and_then(|v| {
            let (scheme, token) = v.trim().split_once(' ')?;
            (scheme.eq_ignore_ascii_case("token") || scheme.eq_ignore_ascii_case("bearer"))
                .then(|| token.trim())
        });
        let cookie_tokens = request.cookies.iter().flat_map(|c| {
            c.split(';').filter_map(|pair| {
                let (name, value) = pair.trim().split_once('=')?;
                (name == self.cookie_name).then_some(value.trim())
            })
        });
        let offered: Vec<&str> = query_token
            .into_iter()
            .chain(header_token)
            .chain(cookie_tokens)
            .collect();
        if offered.is_empty() {
            return Err(Reply::error(
                403,
                "no token: open the URL femto view printed (.../?token=...), or send \
                 'Authorization: token TOKEN' (docs/view.md)",
            ));
        }
        // Every offered token is compared, so the time taken does not say which was right.
        let right = offered.iter().fold(false, |ok, t| {
            same_token(t.as_bytes(), self.token.as_bytes()) | ok
        });
        if !right {
            return Err(Reply::error(
                403,
                "wrong token: use the one in the URL this run of femto view printed",
            ));
        }
        let changes = !matches!(request.method, "GET" | "HEAD");
        if changes || request.websocket {
            if let Some(origin) = request.origin.map(str::trim) {
                let own = format!("http://{host}");
                if !origin.eq_ignore_ascii_case(&own) {
                    return Err(Reply::error(
                        403,
                        format!(
                            "Origin '{}' is not this server's ({own}): only its own page may \
                             change its state or open its frame stream",
                            printable(origin)
                        ),
                    ));
                }
            }
        }
        if matches!(request.method, "POST" | "PUT" | "PATCH") {
            let wanted = if path == "/api/path" {
                "application/toml"
            } else {
                "application/json"
            };
            let given = request
                .content_type
                .map(|c| c.split(';').next().unwrap_or("").trim())
                .unwrap_or("");
            if !given.eq_ignore_ascii_case(wanted) {
                return Err(Reply::error(
                    415,
                    format!(
                        "{} {path}: Content-Type '{}': send '{wanted}'",
                        request.method,
                        printable(given)
                    ),
                ));
            }
        }
        let url = if rest.is_empty() {
            path.to_string()
        } else {
            format!("{path}?{}", rest.join("&"))
        };
        let set_cookie = (query_token.is_some() && request.method == "GET").then(|| {
            format!(
                "{}={}; Path=/; HttpOnly; SameSite=Strict",
                self.cookie_name, self.token
            )
        });
        Ok(Granted { url, set_cookie })
    }

    /// Whether a `Host` header (a name and an optional port) names this server.
    fn host_allowed(&self, host: &str) -> bool {
        let name = if let Some(rest) = host.strip_prefix('[') {
            match rest.split_once(']') {
                Some((inside, port))
                    if port.is_empty() || port.strip_prefix(':').is_some_and(is_port) =>
                {
                    inside
                }
                _ => return false,
            }
        } else {
            match host.rsplit_once(':') {
                Some((name, port)) if is_port(port) => name,
                Some(_) => return false,
                None => host,
            }
        };
        if name.eq_ignore_ascii_case("localhost") {
            return true;
        }
        let Ok(ip) = name.parse::<IpAddr>() else {
            return false;
        };
        ip.is_loopback() || ip == self.bound.ip() || self.bound.ip().is_unspecified()
    }
}

fn is_port(s: &str) -> bool {
    s.parse::<u16>().is_ok()
}

/// Whether two tokens are equal, in time that depends only on their lengths.
fn same_token(a: &[u8], b: &[u8]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    let diff = a.iter().zip(b).fold(0u8, |d, (x, y)| d | (x ^ y));
    std::hint::black_box(diff) == 0
}

/// A header value for a one-line message: at most 80 characters, no control characters.
fn printable(s: &str) -> String {
    s.chars()
        .filter(|c| !c.is_control())
        .take(80)
        .collect::<String>()
}

#[cfg(test)]
mod tests {
    use super::*;

    const TOKEN: &str = "0123abcd";

    fn access() -> Access {
        Access::with_token("127.0.0.1:8765".parse().unwrap(), TOKEN.into())
    }

    fn head<'a>(method: &'a str, url: &'a str) -> RequestHead<'a> {
        RequestHead {
            method,
            url,
            host: Some("127.0.0.1:8765"),
            authorization: Some("token 0123abcd"),
            ..RequestHead::default()
        }
    }

    #[test]
    fn the_token_is_taken_from_the_header_the_query_or_the_cookie() {
        let a = access();
        let g = a.check(&head("GET", "/api/info")).unwrap();
        assert_eq!(g.url, "/api/info");
        assert_eq!(g.set_cookie, None);
        let mut by_query = head("GET", "/?token=0123abcd");
        by_query.authorization = None;
        let g = a.check(&by_query).unwrap();
        assert_eq!(g.url, "/");
        let cookie = g.set_cookie.unwrap();
        assert!(cookie.starts_with("femto_view_8765=0123abcd;"), "{cookie}");
        assert!(cookie.contains("HttpOnly") && cookie.contains("SameSite=Strict"));
        let mut by_cookie = head("GET", "/api/frame?scale=0.5");
        by_cookie.authorization = None;
        by_cookie.cookies = vec!["other=1; femto_view_8765=0123abcd"];
        assert_eq!(a.check(&by_cookie).unwrap().url, "/api/frame?scale=0.5");
        let mut mixed = head("POST", "/api/frame?token=0123abcd&quality=80");
        mixed.authorization = None;
        mixed.content_type = Some("application/json; charset=utf-8");
        assert_eq!(a.check(&mixed).unwrap().url, "/api/frame?quality=80");
    }

    #[test]
    fn no_token_a_wrong_one_or_another_servers_cookie_is_refused() {
        let a = access();
        for (auth, cookie, query) in [
            (None, None, ""),
            (Some("token 0123abce"), None, ""),
            (Some("token 0123abcd0"), None, ""),
            (Some("Basic 0123abcd"), None, ""),
            (None, Some("femto_view_9000=0123abcd"), ""),
            (None, None, "?token="),
            (None, None, "?token=0123ABCD"),
        ] {
            let url = format!("/api/info{query}");
            let mut h = head("GET", &url);
            h.authorization = auth;
            h.cookies = cookie.into_iter().collect();
            let r = a.check(&h).unwrap_err();
            assert_eq!(r.status, 403, "{auth:?} {cookie:?} {query}");
        }
    }

    #[test]
    fn only_names_that_cannot_be_rebound_are_answered() {
        let a = access();
        for host in [
            "127.0.0.1:8765",
            "localhost:8765",
            "LOCALHOST",
            "[::1]:8765",
            "127.0.0.1:9000",
            "127.0.0.1",
        ] {
            let mut h = head("GET", "/");
            h.host = Some(host);
            assert!(a.check(&h).is_ok(), "{host}");
        }
        for host in [
            "evil.example:8765",
            "localhost.evil.example:8765",
            "10.0.0.7:8765",
            "127.0.0.1:port",
            "[::1",
            "",
        ] {
            let mut h = head("GET", "/");
            h.host = Some(host);
            assert_eq!(a.check(&h).unwrap_err().status, 403, "{host}");
        }
        let mut h = head("GET", "/");
        h.host = None;
        assert_eq!(a.check(&h).unwrap_err().status, 403);
        // Bound to every address: any address, but still no name but localhost.
        let all = Access::with_token("0.0.0.0:8765".parse().unwrap(), TOKEN.into());
        let mut h = head("GET", "/");
        h.host = Some("10.0.0.7:8765");
        assert!(all.check(&h).is_ok());
        h.host = Some("lab.example:8765");
        assert_eq!(all.check(&h).unwrap_err().status, 403);
    }

    #[test]
    fn changes_and_websockets_from_other_origins_and_plain_text_posts_are_refused() {
        let a = access();
        let json = Some("application/json");
        let mut h = head("POST", "/api/keyframes");
        h.content_type = json;
        h.origin = Some("http://127.0.0.1:8765");
        assert!(a.check(&h).is_ok());
        h.origin = Some("http://evil.example");
        assert_eq!(a.check(&h).unwrap_err().status, 403);
        h.origin = Some("null");
        assert_eq!(a.check(&h).unwrap_err().status, 403);
        h.origin = None;
        for ct in [
            Some("text/plain"),
            None,
            Some("application/x-www-form-urlencoded"),
        ] {
            h.content_type = ct;
            assert_eq!(a.check(&h).unwrap_err().status, 415, "{ct:?}");
        }
        let mut path = head("POST", "/api/path");
        path.content_type = Some("application/toml");
        assert!(a.check(&path).is_ok());
        let mut del = head("DELETE", "/api/keyframes");
        del.origin = Some("http://localhost:8765");
        assert_eq!(a.check(&del).unwrap_err().status, 403);
        let mut ws = head("GET", "/ws");
        ws.websocket = true;
        ws.origin = Some("http://evil.example:8765");
        assert_eq!(a.check(&ws).unwrap_err().status, 403);
        ws.origin = Some("http://127.0.0.1:8765");
        assert!(a.check(&ws).is_ok());
        // A GET from another origin reads nothing: the browser keeps the reply from it.
        let mut get = head("GET", "/api/info");
        get.origin = Some("http://evil.example");
        assert!(a.check(&get).is_ok());
    }

    #[test]
    fn tokens_are_random_and_compared_whole() {
        let bound = "127.0.0.1:1".parse().unwrap();
        let (a, b) = (Access::new(bound).unwrap(), Access::new(bound).unwrap());
        assert_eq!(a.token().len(), 2 * TOKEN_BYTES);
        assert_ne!(a.token(), b.token());
        assert!(a.url().ends_with(&format!("/?token={}", a.token())));
        assert!(same_token(b"abc", b"abc"));
        assert!(!same_token(b"abc", b"abd"));
        assert!(!same_token(b"abc", b"ab"));
    }
}
