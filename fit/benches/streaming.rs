//! Streaming fit throughput and memory against `numpy.polyfit`.
//!
//! ```text
//! cargo bench -p fit --bench streaming                 # 10^6 and 10^7 points
//! cargo bench -p fit --bench streaming -- --points 3000000 --repeat 5
//! ```
//!
//! For each size the benchmark
//! 1. writes seeded noisy samples of a realistic thrust → power curve,
//!    `P(T) = 0.157434234·T + 0.341190317·(T/100)^5.34865728` W for
//!    T ∈ [0, 260] g, to a temporary `.npy` file holding a (2, N) array
//!    (the x row, then the y row);
//! 2. runs the Rust side in a fresh child process (this executable with
//!    `--child`), so its peak RSS (`VmHWM`) covers only the fit: one cheap
//!    [`RangeScan`] pass over the x row for the domain, then
//!    [`StreamingPolyFit`] fed in chunks read from the file — memory
//!    independent of N;
//! 3. runs `benches/numpy_polyfit.py`, which memory-maps the same file and
//!    times `numpy.polyfit(x, y, 5)`, reporting `ru_maxrss`;
//! 4. prints throughput, the speed ratio, peak memory on both sides and the
//!    largest relative difference between the two sets of coefficients.
//!
//! Both timings include reading the data from the (page-cached) file. Each
//! side runs `--repeat` times (default 3, a fresh process each time); the
//! table reports the fastest run and the largest peak RSS.

use std::fs::File;
use std::io::{BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use fit::{RangeScan, StreamingPolyFit};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

const DEGREE: usize = 5;
const THRUST_MAX_G: f64 = 260.0;
const NOISE_W: f64 = 0.25;
const CHUNK_POINTS: usize = 1 << 16;
const DEFAULT_SIZES: [usize; 2] = [1_000_000, 10_000_000];
/// Each side runs this many times (a fresh process each time); the table
/// shows the fastest run and the largest peak RSS.
const DEFAULT_REPEATS: usize = 3;

fn power_w(thrust_g: f64) -> f64 {
    0.157434234 * thrust_g + 0.341190317 * (thrust_g / 100.0).powf(5.34865728)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if let Some(i) = args.iter().position(|a| a == "--child") {
        let path = args.get(i + 1).expect("--child needs a file path");
        child(Path::new(path));
        return;
    }
    let mut sizes: Vec<usize> = args
        .windows(2)
        .filter(|w| w[0] == "--points")
        .map(|w| w[1].parse().expect("--points takes a positive integer"))
        .collect();
    if sizes.is_empty() {
        sizes = DEFAULT_SIZES.to_vec();
    }
    let repeats: usize = args
        .windows(2)
        .find(|w| w[0] == "--repeat")
        .map_or(DEFAULT_REPEATS, |w| {
            w[1].parse().expect("--repeat takes a positive integer")
        })
        .max(1);
    let rows: Vec<Row> = sizes.iter().map(|&n| run(n, repeats)).collect();
    print_table(&rows);
}

struct Side {
    seconds: f64,
    peak_rss_kib: u64,
    coeffs: Vec<f64>,
}

struct Row {
    n: usize,
    rust: Side,
    rust_fit_seconds: f64,
    rust_start_rss_kib: u64,
    numpy: Result<(Side, u64, String), String>,
}

fn run(n: usize, repeats: usize) -> Row {
    let path = std::env::temp_dir().join(format!(
        "hoverbench-fit-bench-{}-{n}.npy",
        std::process::id()
    ));
    eprintln!("writing {n} points to {} ...", path.display());
    write_npy(&path, n).expect("write benchmark data");

    eprintln!("Rust streaming fit ({repeats}x) ...");
    let mut rust: Option<Side> = None;
    let (mut rust_fit_seconds, mut rust_start_rss_kib) = (f64::INFINITY, 0);
    for _ in 0..repeats {
        let out = Command::new(std::env::current_exe().expect("own executable"))
            .arg("--child")
            .arg(&path)
            .output()
            .expect("run child process");
        assert!(
            out.status.success(),
            "child failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let kv = parse_kv(&String::from_utf8_lossy(&out.stdout));
        let side = Side {
            seconds: num(&kv, "seconds"),
            peak_rss_kib: num(&kv, "peak_rss_kib") as u64,
            coeffs: coeffs(&kv),
        };
        rust_fit_seconds = rust_fit_seconds.min(num(&kv, "fit_seconds"));
        rust_start_rss_kib = rust_start_rss_kib.max(num(&kv, "start_rss_kib") as u64);
        rust = Some(best_of(rust, side));
    }
    let rust = rust.expect("at least one run");

    eprintln!("numpy.polyfit ({repeats}x) ...");
    let mut numpy = run_numpy(&path);
    for _ in 1..repeats {
        numpy = match (numpy, run_numpy(&path)) {
            (Ok((best, baseline, version)), Ok((side, ..))) => {
                Ok((best_of(Some(best), side), baseline, version))
            }
            (first, _) => first,
        };
    }
    let _ = std::fs::remove_file(&path);
    Row {
        n,
        rust,
        rust_fit_seconds,
        rust_start_rss_kib,
        numpy,
    }
}

/// Fastest time and largest peak RSS of the runs so far.
fn best_of(best: Option<Side>, run: Side) -> Side {
    match best {
        None => run,
        Some(b) => Side {
            seconds: b.seconds.min(run.seconds),
            peak_rss_kib: b.peak_rss_kib.max(run.peak_rss_kib),
            coeffs: run.coeffs,
        },
    }
}

fn run_numpy(path: &Path) -> Result<(Side, u64, String), String> {
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("benches/numpy_polyfit.py");
    let out = Command::new("python3")
        .arg(&script)
        .arg(path)
        .arg(DEGREE.to_string())
        .output()
        .map_err(|e| {
            format!("could not run python3 ({e}); install Python 3 and numpy (pip install numpy)")
        })?;
    let text = String::from_utf8_lossy(&out.stdout);
    let kv = parse_kv(&text);
    if !out.status.success() {
        let why = kv
            .iter()
            .find(|(k, _)| k == "error")
            .map(|(_, v)| v.clone())
            .unwrap_or_else(|| String::from_utf8_lossy(&out.stderr).into_owned());
        return Err(why);
    }
    let side = Side {
        seconds: num(&kv, "seconds"),
        peak_rss_kib: num(&kv, "peak_rss_kib") as u64,
        coeffs: coeffs(&kv),
    };
    let version = kv
        .iter()
        .find(|(k, _)| k == "numpy_version")
        .map_or_else(String::new, |(_, v)| v.clone());
    Ok((side, num(&kv, "baseline_rss_kib") as u64, version))
}

/// The Rust measurement, in a process that has allocated nothing else.
fn child(path: &Path) {
    let start_rss = vm_kib("VmHWM");
    let t0 = Instant::now();
    let mut reader = NpyPairs::open(path).expect("open data");
    let (mut xs, mut ys) = (
        Vec::with_capacity(CHUNK_POINTS),
        Vec::with_capacity(CHUNK_POINTS),
    );

    // Pass 1: the domain (fixes the scaling before the fit sees data).
    let mut scan = RangeScan::new();
    while reader.next_x(&mut xs).expect("read") {
        scan.push_chunk(&xs);
    }
    let (lo, hi) = scan.range().expect("data");

    // Pass 2: the streaming fit.
    let t_fit = Instant::now();
    reader.rewind().expect("rewind");
    let mut fit = StreamingPolyFit::new(DEGREE, lo, hi).expect("domain");
    while reader.next_chunk(&mut xs, &mut ys).expect("read") {
        fit.push_chunk(&xs, &ys).expect("finite data in domain");
    }
    let result = fit.finish().expect("fit");
    let fit_seconds = t_fit.elapsed().as_secs_f64();
    let seconds = t0.elapsed().as_secs_f64();

    println!("seconds={seconds}");
    println!("fit_seconds={fit_seconds}");
    println!("start_rss_kib={start_rss}");
    println!("peak_rss_kib={}", vm_kib("VmHWM"));
    let b = result.monomial_coefficients();
    println!(
        "coeffs={}",
        b.iter()
            .map(|c| format!("{c:e}"))
            .collect::<Vec<_>>()
            .join(",")
    );
}

fn vm_kib(field: &str) -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with(field))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|v| v.parse().ok())
        })
        .unwrap_or(0)
}

/// Writes a (2, n) little-endian f64 `.npy` file: the row of thrusts (g),
/// then the row of powers (W). The samples are generated twice from the same
/// seed (once per row) so nothing of size n is held in memory.
fn write_npy(path: &Path, n: usize) -> std::io::Result<()> {
    let mut header = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': (2, {n}), }}");
    let unpadded = 10 + header.len() + 1;
    header.push_str(&" ".repeat((64 - unpadded % 64) % 64));
    header.push('\n');
    let mut w = BufWriter::with_capacity(1 << 20, File::create(path)?);
    w.write_all(b"\x93NUMPY\x01\x00")?;
    w.write_all(
        &u16::try_from(header.len())
            .expect("short header")
            .to_le_bytes(),
    )?;
    w.write_all(header.as_bytes())?;
    for row in 0..2 {
        let mut rng = ChaCha8Rng::seed_from_u64(20_240_601);
        for _ in 0..n {
            let t = rng.random_range(0.0..=THRUST_MAX_G);
            // Box–Muller Gaussian noise.
            let u1: f64 = 1.0 - rng.random::<f64>();
            let u2: f64 = rng.random();
            let noise = NOISE_W * (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
            let v = if row == 0 { t } else { power_w(t) + noise };
            w.write_all(&v.to_le_bytes())?;
        }
    }
    w.flush()
}

/// Chunked reader of a (2, n) `<f8` `.npy` file (x row, then y row).
struct NpyPairs {
    x: File,
    y: File,
    x_start: u64,
    y_start: u64,
    buf: Vec<u8>,
}

impl NpyPairs {
    fn open(path: &Path) -> std::io::Result<NpyPairs> {
        let mut x = File::open(path)?;
        let mut pre = [0u8; 10];
        x.read_exact(&mut pre)?;
        assert_eq!(&pre[..8], b"\x93NUMPY\x01\x00", "unsupported .npy version");
        let header_len = u16::from_le_bytes([pre[8], pre[9]]) as usize;
        let mut header = vec![0u8; header_len];
        x.read_exact(&mut header)?;
        let header = String::from_utf8_lossy(&header);
        assert!(
            header.contains("'<f8'") && header.contains("False"),
            "{header}"
        );
        let n: u64 = header
            .split("(2, ")
            .nth(1)
            .and_then(|rest| rest.split(')').next())
            .and_then(|v| v.parse().ok())
            .expect("shape (2, n)");
        let x_start = (10 + header_len) as u64;
        let mut reader = NpyPairs {
            x,
            y: File::open(path)?,
            x_start,
            y_start: x_start + 8 * n,
            buf: vec![0u8; CHUNK_POINTS * 8],
        };
        reader.rewind()?;
        Ok(reader)
    }

    fn rewind(&mut self) -> std::io::Result<()> {
        self.x.seek(SeekFrom::Start(self.x_start))?;
        self.y.seek(SeekFrom::Start(self.y_start))?;
        Ok(())
    }

    /// Reads up to a chunk of f64 from `file`, stopping at `limit` (a file offset).
    fn read_f64s(
        file: &mut File,
        limit: u64,
        buf: &mut [u8],
        out: &mut Vec<f64>,
    ) -> std::io::Result<()> {
        let pos = file.stream_position()?;
        let want = (buf.len() as u64).min(limit.saturating_sub(pos)) as usize;
        file.read_exact(&mut buf[..want])?;
        out.clear();
        out.extend(
            buf[..want]
                .chunks_exact(8)
                .map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes"))),
        );
        Ok(())
    }

    /// Fills `xs` with the next chunk of x only; `false` at the end.
    fn next_x(&mut self, xs: &mut Vec<f64>) -> std::io::Result<bool> {
        Self::read_f64s(&mut self.x, self.y_start, &mut self.buf, xs)?;
        Ok(!xs.is_empty())
    }

    /// Fills `xs`, `ys` with the next chunk; `false` at the end.
    fn next_chunk(&mut self, xs: &mut Vec<f64>, ys: &mut Vec<f64>) -> std::io::Result<bool> {
        let y_end = self.y_start + (self.y_start - self.x_start);
        Self::read_f64s(&mut self.x, self.y_start, &mut self.buf, xs)?;
        Self::read_f64s(&mut self.y, y_end, &mut self.buf, ys)?;
        Ok(!xs.is_empty())
    }
}

fn parse_kv(text: &str) -> Vec<(String, String)> {
    text.lines()
        .filter_map(|l| l.split_once('='))
        .map(|(k, v)| (k.trim().to_owned(), v.trim().to_owned()))
        .collect()
}

fn num(kv: &[(String, String)], key: &str) -> f64 {
    kv.iter()
        .find(|(k, _)| k == key)
        .and_then(|(_, v)| v.parse().ok())
        .unwrap_or_else(|| panic!("missing {key} in {kv:?}"))
}

fn coeffs(kv: &[(String, String)]) -> Vec<f64> {
    kv.iter()
        .find(|(k, _)| k == "coeffs")
        .map(|(_, v)| {
            v.split(',')
                .map(|c| c.parse().expect("coefficient"))
                .collect()
        })
        .expect("coefficients")
}

fn horner(c: &[f64], x: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &a| acc * x + a)
}

fn mib(kib: u64) -> f64 {
    kib as f64 / 1024.0
}

fn print_table(rows: &[Row]) {
    println!();
    println!(
        "degree-{DEGREE} fit of P(T) = 0.157434234·T + 0.341190317·(T/100)^5.34865728 + N(0, {NOISE_W}²) W, T ∈ [0, {THRUST_MAX_G}] g"
    );
    println!();
    println!(
        "{:>10} | {:>9} {:>11} {:>10} | {:>9} {:>11} {:>10} | {:>7} | {:>10} {:>10}",
        "points",
        "Rust s",
        "Rust pts/s",
        "Rust MiB",
        "numpy s",
        "numpy pts/s",
        "numpy MiB",
        "speedup",
        "max rel Δb",
        "max rel Δp"
    );
    for r in rows {
        let n = r.n as f64;
        let rust = format!(
            "{:>9.3} {:>11.3e} {:>10.1}",
            r.rust.seconds,
            n / r.rust.seconds,
            mib(r.rust.peak_rss_kib)
        );
        match &r.numpy {
            Ok((np, _, _)) => {
                let rel_b = r
                    .rust
                    .coeffs
                    .iter()
                    .zip(&np.coeffs)
                    .map(|(a, b)| ((a - b) / b).abs())
                    .fold(0.0, f64::max);
                let grid = (0..=1000).map(|i| THRUST_MAX_G * f64::from(i) / 1000.0);
                let p_scale = grid
                    .clone()
                    .map(|t| horner(&np.coeffs, t).abs())
                    .fold(0.0, f64::max);
                let rel_p = grid
                    .map(|t| (horner(&r.rust.coeffs, t) - horner(&np.coeffs, t)).abs())
                    .fold(0.0, f64::max)
                    / p_scale;
                println!(
                    "{:>10} | {rust} | {:>9.3} {:>11.3e} {:>10.1} | {:>6.1}x | {:>10.2e} {:>10.2e}",
                    r.n,
                    np.seconds,
                    n / np.seconds,
                    mib(np.peak_rss_kib),
                    np.seconds / r.rust.seconds,
                    rel_b,
                    rel_p
                );
            }
            Err(_) => println!(
                "{:>10} | {rust} | {:>9} {:>11} {:>10} | {:>7} | {:>10} {:>10}",
                r.n, "-", "-", "-", "-", "-", "-"
            ),
        }
    }
    println!();
    for r in rows {
        println!(
            "{:>10} points: Rust fit pass alone {:.3} s ({:.3e} pts/s; the rest is the RangeScan pass); \
             Rust process RSS at start {:.1} MiB",
            r.n,
            r.rust_fit_seconds,
            r.n as f64 / r.rust_fit_seconds,
            mib(r.rust_start_rss_kib)
        );
        match &r.numpy {
            Ok((_, baseline, version)) => println!(
                "{:>10} points: numpy {version}: RSS after `import numpy` {:.1} MiB (peak includes the memory-mapped data)",
                r.n,
                mib(*baseline)
            ),
            Err(why) => println!("{:>10} points: numpy side not run: {why}", r.n),
        }
    }
    println!(
        "Rust coefficients (W/g^k): {:?}",
        rows.last().map(|r| &r.rust.coeffs)
    );
}
