//! Records the git commit the binary is built from (`host-tool --version`). A source tree
//! without `.git` (a tarball) or without git builds too: the commit is then `unknown`.

use std::process::Command;

fn main() {
    let commit = Command::new("git")
        .args(["rev-parse", "--short=12", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .map(|c| {
            let dirty = Command::new("git")
                .args(["status", "--porcelain", "--untracked-files=no"])
                .output()
                .ok()
                .is_some_and(|o| o.status.success() && !o.stdout.is_empty());
            if dirty {
                format!("{c}-modified")
            } else {
                c
            }
        })
        .unwrap_or_else(|| "unknown".to_string());
    println!("cargo:rustc-env=HOST_TOOL_GIT_COMMIT={commit}");
    println!("cargo:rerun-if-changed=build.rs");
    // Rebuilt when HEAD moves (a commit, a checkout: the reflog grows) or the index changes.
    let git_dir = Command::new("git")
        .args(["rev-parse", "--absolute-git-dir"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok());
    if let Some(dir) = git_dir {
        let dir = std::path::Path::new(dir.trim());
        for f in ["HEAD", "index", "logs/HEAD"] {
            if dir.join(f).exists() {
                println!("cargo:rerun-if-changed={}", dir.join(f).display());
            }
        }
    }
}
