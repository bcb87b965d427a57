//! Fault cases: outputs (issue 16).

#[allow(unused_imports)]
use super::{case, cli};
