//! Fault cases: consistency (issue 16).

#[allow(unused_imports)]
use super::{case, cli};
