//! A held-out file that is also a training file.
//!
//! Where the user gives the training and the held-out set (`gap FLIGHTS --holdout FLIGHTS`,
//! `rig-gap SWEEPS --holdout SWEEPS`), a file in both would be trained on and then scored as if
//! unseen, and the held-out figures would flatter the model. A file counts as the same when it
//! has the same canonical path (the same file under another name, `./a` against `a`, or through
//! a link) or the same bytes (a copy in another folder is the same flight).

use std::collections::HashMap;
use std::hash::{DefaultHasher, Hash, Hasher};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

/// How a held-out file matches a training file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Same {
    /// The same file (same canonical path).
    Path,
    /// Another file with the same bytes.
    Content,
}

/// A held-out file that is also a training file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Overlap {
    /// The held-out file, as given.
    pub heldout: PathBuf,
    /// The training file it matches, as given.
    pub train: PathBuf,
    /// How they match.
    pub same: Same,
}

/// One file's identity: canonical path, and its bytes' length and hash.
struct Identity {
    canonical: PathBuf,
    len: usize,
    hash: u64,
}

fn identity(p: &Path) -> Result<Identity> {
    let canonical = p
        .canonicalize()
        .with_context(|| format!("resolving {}", p.display()))?;
    let bytes = std::fs::read(p).with_context(|| format!("reading {}", p.display()))?;
    let mut h = DefaultHasher::new();
    bytes.hash(&mut h);
    Ok(Identity {
        canonical,
        len: bytes.len(),
        hash: h.finish(),
    })
}

fn same_bytes(a: &Path, b: &Path) -> Result<bool> {
    let read = |p: &Path| std::fs::read(p).with_context(|| format!("reading {}", p.display()));
    Ok(read(a)? == read(b)?)
}

/// Every held-out file that is also a training file (each held-out file once, with the first
/// training file it matches). Paths that appear twice in one set are compared once.
pub fn overlaps(train: &[PathBuf], heldout: &[PathBuf]) -> Result<Vec<Overlap>> {
    let mut by_path: HashMap<PathBuf, &Path> = HashMap::new();
    let mut by_content: HashMap<(usize, u64), Vec<&Path>> = HashMap::new();
    for t in train {
        let id = identity(t)?;
        if by_path.contains_key(&id.canonical) {
            continue;
        }
        by_path.insert(id.canonical, t);
        by_content.entry((id.len, id.hash)).or_default().push(t);
    }
    let mut out = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for h in heldout {
        let id = identity(h)?;
        if !seen.insert(id.canonical.clone()) {
            continue;
        }
        if let Some(t) = by_path.get(&id.canonical) {
            out.push(Overlap {
                heldout: h.clone(),
                train: t.to_path_buf(),
                same: Same::Path,
            });
            continue;
        }
        // Equal hashes are confirmed byte by byte.
        for t in by_content.get(&(id.len, id.hash)).into_iter().flatten() {
            if same_bytes(h, t)? {
                out.push(Overlap {
                    heldout: h.clone(),
                    train: t.to_path_buf(),
                    same: Same::Content,
                });
                break;
            }
        }
    }
    Ok(out)
}

/// Refuses a held-out set that shares a file with the training set, naming every such file.
/// `what` names the items ("flight", "stand log").
pub fn refuse(train: &[PathBuf], heldout: &[PathBuf], what: &str) -> Result<()> {
    let found = overlaps(train, heldout)?;
    if found.is_empty() {
        return Ok(());
    }
    let list: Vec<String> = found
        .iter()
        .map(|o| match o.same {
            Same::Path if o.heldout == o.train => {
                format!("{} is also given for training", o.heldout.display())
            }
            Same::Path => format!(
                "{} is the training {what} {}",
                o.heldout.display(),
                o.train.display()
            ),
            Same::Content => format!(
                "{} has the same bytes as the training {what} {}",
                o.heldout.display(),
                o.train.display()
            ),
        })
        .collect();
    bail!(
        "{} held-out {what}(s) also in the training set: {}. A {what} held out must not be trained on (its held-out error would flatter the model): remove it from one set",
        found.len(),
        list.join("; ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_path_same_bytes_and_distinct_files() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b, c) = (
            dir.path().join("a.csv"),
            dir.path().join("b.csv"),
            dir.path().join("sub/a.csv"),
        );
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        std::fs::write(&a, "time_s,voltage_v\n0,12.6\n").unwrap();
        std::fs::write(&b, "time_s,voltage_v\n0,12.5\n").unwrap();
        std::fs::write(&c, "time_s,voltage_v\n0,12.6\n").unwrap();
        // Distinct content: nothing.
        assert!(
            overlaps(std::slice::from_ref(&a), std::slice::from_ref(&b))
                .unwrap()
                .is_empty()
        );
        // The same file by another spelling.
        let dotted = dir.path().join("sub/../a.csv");
        let o = overlaps(&[a.clone(), b.clone()], std::slice::from_ref(&dotted)).unwrap();
        assert_eq!(o.len(), 1);
        assert_eq!((o[0].same, &o[0].train), (Same::Path, &a));
        // A copy in another folder.
        let o = overlaps(&[b.clone(), a.clone()], std::slice::from_ref(&c)).unwrap();
        assert_eq!(o.len(), 1);
        assert_eq!((o[0].same, &o[0].train), (Same::Content, &a));
        let e = refuse(std::slice::from_ref(&a), &[b.clone(), c.clone()], "flight")
            .unwrap_err()
            .to_string();
        assert!(e.contains("1 held-out flight(s)"), "{e}");
        assert!(e.contains(&c.display().to_string()), "{e}");
        assert!(e.contains(&a.display().to_string()), "{e}");
        assert!(!e.contains(&b.display().to_string()), "{e}");
    }
}
