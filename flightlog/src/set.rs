//! A flight set: a folder of logs with their metadata.

use std::path::{Path, PathBuf};

use crate::{Flight, FlightLogError, FlightMeta, LogFormat, MetaSource, crazyflie};

/// Name of a folder's metadata defaults.
pub const DEFAULTS_FILE: &str = "flights.toml";

/// A file that was not read as a flight, and why.
#[derive(Debug)]
pub struct Skipped {
    /// The file.
    pub path: PathBuf,
    /// Why: the error that stopped it.
    pub reason: FlightLogError,
}

impl Skipped {
    /// Why, with the causes, on one line; without the file name the reason starts with (that
    /// is [`Skipped::path`], shown beside it).
    pub fn why(&self) -> String {
        let file = self.path.display().to_string();
        let reason = crate::summary::error_chain(&self.reason);
        if let Some(rest) = reason
            .strip_prefix(&format!("{file}: "))
            .or_else(|| reason.strip_prefix(&format!("{file}, ")))
        {
            return rest.to_owned();
        }
        // "cannot read FILE: why" → "cannot read: why"
        reason.replacen(&format!(" {file}"), "", 1)
    }
}

/// The flights of a folder, the files that could not be read, and the folder's defaults.
#[derive(Debug)]
pub struct FlightSet {
    /// Flights read, in natural order of their names (`flight2` before `flight10`).
    pub flights: Vec<Flight>,
    /// Files that could not be read, with the reason.
    pub skipped: Vec<Skipped>,
    /// The folder's defaults: platform defaults (for the Crazyflie layout) with its
    /// `flights.toml` merged over them.
    pub defaults: FlightMeta,
}

/// Whether a path has a flight-log extension.
fn is_log(path: &Path) -> bool {
    path.extension().and_then(|e| e.to_str()).is_some_and(|e| {
        ["csv", "ulg", "bin", "log", "tlog"]
            .iter()
            .any(|x| e.eq_ignore_ascii_case(x))
    })
}

/// Orders names so that embedded runs of digits compare by value (`flight2` < `flight10`,
/// `a02` = `a2` by value, the shorter run of zeros first to keep the order total), then byte
/// by byte. The one natural order of the workspace: flight sets and the diagnosis both use it.
pub fn natural_cmp(a: &str, b: &str) -> std::cmp::Ordering {
    by_number(a.as_bytes(), b.as_bytes()).then_with(|| a.cmp(b))
}

/// [`natural_cmp`] without its final byte-by-byte tie-break.
fn by_number(mut a: &[u8], mut b: &[u8]) -> std::cmp::Ordering {
    loop {
        match (a.first(), b.first()) {
            (None, None) => return std::cmp::Ordering::Equal,
            (None, _) => return std::cmp::Ordering::Less,
            (_, None) => return std::cmp::Ordering::Greater,
            (Some(x), Some(y)) if x.is_ascii_digit() && y.is_ascii_digit() => {
                let da = a.iter().take_while(|c| c.is_ascii_digit()).count();
                let db = b.iter().take_while(|c| c.is_ascii_digit()).count();
                let (na, nb) = (&a[..da], &b[..db]);
                let strip = |n: &[u8]| -> usize { n.iter().take_while(|&&c| c == b'0').count() };
                let (ta, tb) = (&na[strip(na)..], &nb[strip(nb)..]);
                let ord = ta.len().cmp(&tb.len()).then_with(|| ta.cmp(tb));
                if ord != std::cmp::Ordering::Equal {
                    return ord;
                }
                a = &a[da..];
                b = &b[db..];
            }
            (Some(x), Some(y)) => {
                if x != y {
                    return x.cmp(y);
                }
                a = &a[1..];
                b = &b[1..];
            }
        }
    }
}

/// Files of a folder, sorted naturally by name.
fn list(dir: &Path) -> Result<Vec<PathBuf>, FlightLogError> {
    let io = |error| FlightLogError::Io {
        path: dir.to_owned(),
        error,
    };
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(io)? {
        let path = entry.map_err(io)?.path();
        if path.is_file() {
            files.push(path);
        }
    }
    files.sort_by(|a, b| {
        natural_cmp(
            &a.file_name().unwrap_or_default().to_string_lossy(),
            &b.file_name().unwrap_or_default().to_string_lossy(),
        )
    });
    Ok(files)
}

impl FlightSet {
    /// Reads a flight folder: every `*.csv`, `*.ulg`, `*.bin`, `*.log` and `*.tlog` in it (or, for the Crazyflie
    /// dataset's layout, every `Real_path/*.csv` with its planned trajectory), each with its
    /// sidecar `NAME.toml` merged over the folder's `flights.toml`.
    ///
    /// Errors only when the folder cannot be listed, its `flights.toml` is invalid, or it holds
    /// no log at all; a log that cannot be read is listed in [`FlightSet::skipped`], as is a
    /// sidecar without a log.
    pub fn read(dir: &Path) -> Result<Self, FlightLogError> {
        let dataset = crazyflie::is_dataset_folder(dir);
        let log_dir = if dataset {
            dir.join(crazyflie::REAL_PATH_DIR)
        } else {
            dir.to_owned()
        };
        let files = list(&log_dir)?;
        let logs: Vec<PathBuf> = files.iter().filter(|p| is_log(p)).cloned().collect();
        let mut set = Self::read_files(dir, &logs)?;
        // Sidecars without a log.
        for path in &files {
            let is_sidecar = path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("toml"))
                && path.file_name().is_some_and(|n| n != DEFAULTS_FILE);
            if is_sidecar && !logs.iter().any(|l| l.file_stem() == path.file_stem()) {
                set.skipped.push(Skipped {
                    path: path.clone(),
                    reason: FlightLogError::UnknownFormat {
                        path: path.clone(),
                        message: "a metadata sidecar without a flight log of the same name"
                            .to_owned(),
                    },
                });
            }
        }
        if set.flights.is_empty() && set.skipped.is_empty() {
            let mut subfolders: Vec<String> = std::fs::read_dir(dir)
                .map(|entries| {
                    entries
                        .filter_map(Result::ok)
                        .filter(|e| e.path().is_dir())
                        .map(|e| e.file_name().to_string_lossy().into_owned())
                        .filter(|n| !n.starts_with('.'))
                        .collect()
                })
                .unwrap_or_default();
            subfolders.sort();
            return Err(FlightLogError::NoFlights {
                path: dir.to_owned(),
                subfolders,
            });
        }
        Ok(set)
    }

    /// Reads the given logs as one set whose defaults are `dir/flights.toml` (when present),
    /// over the Crazyflie platform defaults when `dir` has the Crazyflie dataset's layout. Each
    /// log's sidecar is `NAME.toml` beside it; a Crazyflie log (recognised by its header) gets
    /// the platform defaults under the folder's wherever it lies. A log that cannot be read
    /// goes to [`FlightSet::skipped`].
    pub fn read_files(dir: &Path, logs: &[PathBuf]) -> Result<Self, FlightLogError> {
        let crazyflie_platform = crazyflie::is_dataset_folder(dir);
        let defaults_path = dir.join(DEFAULTS_FILE);
        let folder_file = if defaults_path.is_file() {
            Some(FlightMeta::read(&defaults_path)?)
        } else {
            None
        };
        let folder = folder_file.clone().unwrap_or_default();
        let platform = crazyflie::platform_defaults();
        let defaults = if crazyflie_platform {
            folder.merged_over(&platform)
        } else {
            folder.clone()
        };
        let results: Vec<Result<Flight, FlightLogError>> = read_parallel(logs, |path| {
            read_one(
                path,
                folder_file.as_ref().map(|m| (m, defaults_path.as_path())),
                &platform,
                crazyflie_platform,
            )
        });
        let mut set = FlightSet {
            flights: Vec::new(),
            skipped: Vec::new(),
            defaults,
        };
        for (path, result) in logs.iter().zip(results) {
            match result {
                Ok(f) => set.flights.push(f),
                Err(reason) => set.skipped.push(Skipped {
                    path: path.clone(),
                    reason,
                }),
            }
        }
        Ok(set)
    }

    /// Reads folders and log files as one set: each folder as [`FlightSet::read`], each file
    /// with its folder's `flights.toml` and its sidecar as [`FlightSet::read_files`]. The
    /// defaults are the first path's. Errors when a path does not exist, a folder cannot be
    /// read or holds no log, or a `flights.toml` is invalid.
    pub fn read_paths(paths: &[PathBuf]) -> Result<Self, FlightLogError> {
        let mut out: Option<FlightSet> = None;
        for p in paths {
            let set = if p.is_dir() {
                Self::read(p)?
            } else if p.exists() {
                let dir = p
                    .parent()
                    .filter(|d| !d.as_os_str().is_empty())
                    .unwrap_or(Path::new("."));
                Self::read_files(dir, std::slice::from_ref(p))?
            } else {
                return Err(FlightLogError::Io {
                    path: p.clone(),
                    error: std::io::Error::new(
                        std::io::ErrorKind::NotFound,
                        "no such file or folder",
                    ),
                });
            };
            match out.as_mut() {
                None => out = Some(set),
                Some(all) => {
                    all.flights.extend(set.flights);
                    all.skipped.extend(set.skipped);
                }
            }
        }
        Ok(out.unwrap_or(FlightSet {
            flights: Vec::new(),
            skipped: Vec::new(),
            defaults: FlightMeta::default(),
        }))
    }

    /// A flight by name.
    pub fn get(&self, name: &str) -> Option<&Flight> {
        self.flights.iter().find(|f| f.name == name)
    }
}

/// Reads one log with its sidecar and (Crazyflie) planned trajectory.
fn read_one(
    path: &Path,
    folder: Option<(&FlightMeta, &Path)>,
    platform: &FlightMeta,
    crazyflie_platform: bool,
) -> Result<Flight, FlightLogError> {
    let mut flight = Flight::read(path)?;
    let crazyflie = crazyflie_platform || flight.format == LogFormat::Crazyflie;
    let below = if crazyflie {
        vec![crate::MetaLayer::new(
            platform.clone(),
            MetaSource::Default {
                what: "Crazyflie 2.0 platform".to_owned(),
            },
        )]
    } else {
        Vec::new()
    };
    let mut above = Vec::new();
    if let Some((meta, path)) = folder {
        above.push(crate::MetaLayer::new(
            meta.clone(),
            MetaSource::Folder {
                path: path.to_owned(),
            },
        ));
    }
    let sidecar = path.with_extension("toml");
    if sidecar.is_file() {
        above.push(crate::MetaLayer::new(
            FlightMeta::read(&sidecar)?,
            MetaSource::Sidecar { path: sidecar },
        ));
    }
    flight.set_metadata(&below, &above);
    flight.check_battery()?;
    if flight.format == LogFormat::Crazyflie
        && let Some(plan) = crazyflie::plan_path(path)
    {
        if plan.is_file() {
            match crazyflie::read_plan(&plan) {
                Ok(waypoints) => flight.planned_waypoints_m = Some(waypoints),
                Err(e) => flight.warnings.push(format!(
                    "planned trajectory not read: {}",
                    crate::summary::error_chain(&e)
                )),
            }
        } else if crazyflie_platform {
            flight
                .warnings
                .push(format!("no planned trajectory {}", plan.display()));
        }
    }
    Ok(flight)
}

/// Maps `f` over `items` on up to [`std::thread::available_parallelism`] threads, keeping order.
fn read_parallel<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    let threads = std::thread::available_parallelism()
        .map_or(1, std::num::NonZeroUsize::get)
        .clamp(1, 8)
        .min(items.len().max(1));
    if threads <= 1 {
        return items.iter().map(&f).collect();
    }
    let chunk = items.len().div_ceil(threads);
    std::thread::scope(|scope| {
        let handles: Vec<_> = items
            .chunks(chunk)
            .map(|part| {
                let f = &f;
                scope.spawn(move || part.iter().map(f).collect::<Vec<R>>())
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
            .collect()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn why_names_the_file_once() {
        let path = PathBuf::from("/nowhere/f1.ulg");
        let skipped = Skipped {
            reason: FlightLogError::Io {
                path: path.clone(),
                error: std::io::Error::from(std::io::ErrorKind::NotFound),
            },
            path,
        };
        let why = skipped.why();
        assert!(!why.contains("f1.ulg"), "{why}");
        assert!(why.starts_with("cannot read: "), "{why}");
    }

    #[test]
    fn natural_order() {
        let mut v = vec![
            "Real_path_10",
            "Real_path_2",
            "Real_path_1",
            "a",
            "Real_path_02x",
        ];
        v.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(
            v,
            [
                "Real_path_1",
                "Real_path_2",
                "Real_path_02x",
                "Real_path_10",
                "a"
            ]
        );
    }
}
