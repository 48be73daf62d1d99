//! Which code produced a result: the git commit of the working directory, if `git rev-parse`
//! works there, marked "-dirty" when tracked files have uncommitted changes.

use std::process::Command;

/// The short commit hash (12 digits) of the current directory's repository, with "-dirty"
/// appended when tracked files differ from it; `None` when git or the repository is missing.
pub fn commit() -> Option<String> {
    let out = Command::new("git")
        .args(["rev-parse", "--short=12", "HEAD"])
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    let hash = String::from_utf8(out.stdout).ok()?.trim().to_string();
    if hash.is_empty() {
        return None;
    }
    let dirty = Command::new("git")
        .args(["status", "--porcelain", "--untracked-files=no"])
        .output()
        .map(|o| o.status.success() && !o.stdout.is_empty())
        .unwrap_or(false);
    Some(if dirty { format!("{hash}-dirty") } else { hash })
}
