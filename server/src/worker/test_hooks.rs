//! Hooks that let the tests stop the worker at a precise point (no effect unless the variable
//! is set): [`hold`] waits while the file an environment variable names exists.

use std::time::Duration;

use tracing::info;

/// While the file `var` names exists, waits (logging `what` once, then "(test hook)").
pub fn hold(var: &str, what: &str) {
    let Some(f) = std::env::var_os(var) else {
        return;
    };
    let f = std::path::Path::new(&f);
    if f.exists() {
        info!("{what} (test hook)");
    }
    while f.exists() {
        std::thread::sleep(Duration::from_millis(20));
    }
}
