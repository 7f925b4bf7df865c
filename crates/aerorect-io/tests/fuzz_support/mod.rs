//! A seeded mutation fuzzer for aerorect-io's readers (see `tests/fuzz.rs` for how to run it).
//! Input `i` of a run with seed `s` is a mutation of one seed file chosen by a generator seeded
//! from (s, i) alone, so any input can be rebuilt from its number (`AERORECT_FUZZ_REPLAY=i`).
//! Workers take input numbers from a shared counter; each writes the number it is on to a
//! progress file, so an abort (stack overflow, an allocation over the hard cap) still names it.

pub mod alloc;
pub mod mutate;
pub mod seeds;
pub mod targets;

use mutate::Rng;
use seeds::Seed;
use std::collections::BTreeMap;
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use targets::Verdict;

pub struct Config {
    pub seed: u64,
    /// Stop after this many inputs (None: only the time limit).
    pub inputs: Option<u64>,
    pub seconds: Option<f64>,
    pub threads: usize,
}

/// A broken property, first seen on input `index`.
#[derive(Debug, Clone)]
pub struct Finding {
    pub index: u64,
    pub seed: String,
    pub reader: &'static str,
    pub what: String,
    pub saved: PathBuf,
}

#[derive(Default)]
pub struct Summary {
    pub inputs: u64,
    pub seconds: f64,
    /// Per reader: (calls, Ok results, Err results).
    pub calls: BTreeMap<&'static str, (u64, u64, u64)>,
    /// One finding per (reader, first line of what) pair.
    pub findings: Vec<Finding>,
    /// The slowest reader call: seconds, reader, input.
    pub slowest: (f64, &'static str, u64),
    /// The largest allocation peak of a reader call: bytes, reader, input.
    pub largest_peak: (usize, &'static str, u64),
}

/// Where inputs that broke a property and the workers' progress files go.
pub fn out_dir() -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("fuzz");
    std::fs::create_dir_all(&d).expect("fuzz output folder");
    d
}

/// Input `index` of a run with `seed`: which seed file it mutates, and the bytes.
pub fn input(seeds: &[Seed], seed: u64, index: u64) -> (usize, Vec<u8>) {
    let mut rng = Rng::for_input(seed, index);
    let s = rng.below(seeds.len());
    // One input in sixteen is the seed itself, so the unmutated paths stay exercised.
    let bytes = if rng.chance(16) {
        seeds[s].bytes.clone()
    } else {
        mutate::mutate(&mut rng, &seeds[s], seeds)
    };
    (s, bytes)
}

fn record(
    sum: &mut Summary,
    seeds: &[Seed],
    s: usize,
    index: u64,
    bytes: &[u8],
    calls: Vec<targets::Call>,
) {
    sum.inputs += 1;
    for c in calls {
        let e = sum.calls.entry(c.reader).or_default();
        e.0 += 1;
        if c.seconds > sum.slowest.0 {
            sum.slowest = (c.seconds, c.reader, index);
        }
        if c.peak > sum.largest_peak.0 {
            sum.largest_peak = (c.peak, c.reader, index);
        }
        match c.verdict {
            Verdict::Ok => e.1 += 1,
            Verdict::Err => e.2 += 1,
            Verdict::Finding(what) => {
                let key = what
                    .lines()
                    .next()
                    .unwrap_or("")
                    .chars()
                    .take(120)
                    .collect::<String>();
                let seen = sum
                    .findings
                    .iter()
                    .any(|f| f.reader == c.reader && f.what.starts_with(&key));
                if !seen {
                    let saved = out_dir().join(format!("finding-{index}-{}", seeds[s].name));
                    std::fs::write(&saved, bytes).expect("save finding");
                    sum.findings.push(Finding {
                        index,
                        seed: seeds[s].name.clone(),
                        reader: c.reader,
                        what,
                        saved,
                    });
                }
            }
        }
    }
}

/// Runs the fuzzer and returns what it tried and found.
pub fn run(cfg: &Config) -> Summary {
    targets::install_panic_hook();
    let scratch = tempfile::tempdir().expect("scratch folder");
    let seeds = Arc::new(seeds::all(scratch.path()));
    let next = Arc::new(AtomicU64::new(0));
    let stop = Arc::new(AtomicBool::new(false));
    let total = Arc::new(Mutex::new(Summary::default()));
    let t0 = Instant::now();
    // The input each worker is on and since when (ms after t0), for the hang watchdog.
    let current: Arc<Vec<(AtomicU64, AtomicU64)>> = Arc::new(
        (0..cfg.threads)
            .map(|_| (AtomicU64::new(u64::MAX), AtomicU64::new(0)))
            .collect(),
    );
    let workers: Vec<_> = (0..cfg.threads)
        .map(|w| {
            let (seeds, next, stop, total, current) = (
                seeds.clone(),
                next.clone(),
                stop.clone(),
                total.clone(),
                current.clone(),
            );
            let (seed, limit) = (cfg.seed, cfg.inputs.unwrap_or(u64::MAX));
            let dir = scratch.path().join(format!("w{w}"));
            std::fs::create_dir_all(&dir).expect("worker folder");
            std::thread::Builder::new()
                .name(format!("fuzz-{w}"))
                .stack_size(8 << 20)
                .spawn(move || {
                    let progress =
                        std::fs::File::create(out_dir().join(format!("worker-{w}.progress")))
                            .expect("progress file");
                    let mut sum = Summary::default();
                    while !stop.load(Ordering::Relaxed) {
                        let index = next.fetch_add(1, Ordering::Relaxed);
                        if index >= limit {
                            break;
                        }
                        let line = format!("seed {seed} input {index:<20}\n");
                        let _ = progress.write_at(line.as_bytes(), 0);
                        current[w]
                            .1
                            .store(t0.elapsed().as_millis() as u64, Ordering::Relaxed);
                        current[w].0.store(index, Ordering::Relaxed);
                        let (s, bytes) = input(&seeds, seed, index);
                        let calls = targets::run(seeds[s].kind, &bytes, &dir);
                        record(&mut sum, &seeds, s, index, &bytes, calls);
                        current[w].0.store(u64::MAX, Ordering::Relaxed);
                    }
                    merge(&mut total.lock().expect("summary"), sum);
                })
                .expect("spawn worker")
        })
        .collect();
    watch(cfg, &stop, &current, &workers, t0, &seeds);
    for w in workers {
        w.join().expect("worker");
    }
    let mut sum = std::mem::take(&mut *total.lock().expect("summary"));
    sum.seconds = t0.elapsed().as_secs_f64();
    sum
}

/// Stops the workers at the time limit, and reports a reader stuck on one input for a minute
/// (a hang cannot be interrupted: the input is saved and the process exits).
fn watch(
    cfg: &Config,
    stop: &AtomicBool,
    current: &[(AtomicU64, AtomicU64)],
    workers: &[std::thread::JoinHandle<()>],
    t0: Instant,
    seeds: &[Seed],
) {
    while workers.iter().any(|w| !w.is_finished()) {
        std::thread::sleep(Duration::from_millis(50));
        let now = t0.elapsed();
        if cfg.seconds.is_some_and(|s| now.as_secs_f64() >= s) {
            stop.store(true, Ordering::Relaxed);
        }
        for (index, since) in current {
            let i = index.load(Ordering::Relaxed);
            let ms =
                now.as_millis() as u64 - since.load(Ordering::Relaxed).min(now.as_millis() as u64);
            if i != u64::MAX && ms > 60_000 {
                let (s, bytes) = input(seeds, cfg.seed, i);
                let saved = out_dir().join(format!("hang-{i}-{}", seeds[s].name));
                std::fs::write(&saved, bytes).expect("save hang");
                eprintln!(
                    "FUZZ HANG: input {i} (from {}) ran over 60 s; saved {}",
                    seeds[s].name,
                    saved.display()
                );
                std::process::exit(2);
            }
        }
    }
}

fn merge(into: &mut Summary, s: Summary) {
    into.inputs += s.inputs;
    for (k, v) in s.calls {
        let e = into.calls.entry(k).or_default();
        *e = (e.0 + v.0, e.1 + v.1, e.2 + v.2);
    }
    for f in s.findings {
        if !into
            .findings
            .iter()
            .any(|g| g.reader == f.reader && g.what == f.what)
        {
            into.findings.push(f);
        }
    }
    if s.slowest.0 > into.slowest.0 {
        into.slowest = s.slowest;
    }
    if s.largest_peak.0 > into.largest_peak.0 {
        into.largest_peak = s.largest_peak;
    }
}

/// The summary as printed by the bounded pass in .ci/run.
pub fn report(cfg: &Config, s: &Summary) -> String {
    let mut out = format!(
        "fuzz: {} inputs in {:.1} s ({:.0}/s, seed {}, {} threads), {} findings\n",
        s.inputs,
        s.seconds,
        s.inputs as f64 / s.seconds.max(1e-9),
        cfg.seed,
        cfg.threads,
        s.findings.len()
    );
    for (reader, (n, ok, err)) in &s.calls {
        out += &format!("  {reader:<28} {n:>9} calls {ok:>8} ok {err:>8} refused\n");
    }
    out += &format!(
        "  slowest call {:.3} s ({} on input {}); largest peak {:.1} MiB ({} on input {})\n",
        s.slowest.0,
        s.slowest.1,
        s.slowest.2,
        s.largest_peak.0 as f64 / (1 << 20) as f64,
        s.largest_peak.1,
        s.largest_peak.2
    );
    for f in &s.findings {
        out += &format!(
            "  FINDING input {} (from {}), {}: {}\n    saved {}\n",
            f.index,
            f.seed,
            f.reader,
            f.what,
            f.saved.display()
        );
    }
    out
}
