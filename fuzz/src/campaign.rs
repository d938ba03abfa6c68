//! A campaign: executions of one target on inputs mutated from its corpus, each checked for a
//! panic, a check of the target broken, more work than its counted limits (allocations and the
//! bytes they ask for) and more than 1 GiB of heap; a watchdog reports an execution that does not
//! end. Every finding is saved as the input
//! that caused it, and execution `n` of seed `s` can be made again alone (`input_at`).

use std::cell::RefCell;
use std::fs::File;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, Once};
use std::time::{Duration, Instant};

use super::material::Material;
use super::mutate;
use super::rng::Rng;
use super::targets::{Context, Outcome, Target, Verdict};
use super::watch::{self, ThreadClock, Usage, MEMORY_LIMIT_BYTES};

/// The most work one execution may do, counted by the allocator: a bound that is the same in
/// every build and under any load.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Work {
    pub allocations: u64,
    pub allocated_bytes: u64,
}

impl Work {
    /// [`watch::MOST_ALLOCATIONS`] and [`watch::MOST_ALLOCATED_BYTES`].
    pub const LIMIT: Work = Work {
        allocations: watch::MOST_ALLOCATIONS,
        allocated_bytes: watch::MOST_ALLOCATED_BYTES,
    };
}

/// CPU time after which the watchdog stops waiting for an execution: it catches a hang only. An
/// execution that ends is judged by its counted work ([`Work`]), never by a clock, which depends
/// on the build, the profile and the load (release campaigns have seen 1.2 s executions that
/// end well within the counts).
pub const HANG_CPU: Duration = Duration::from_secs(10);
/// Wall time, in multiples of the CPU time above, after which the watchdog stops waiting
/// whatever the CPU time (a reader blocked).
const HANG_WALL_FACTOR: u32 = 12;

/// The stack the target runs on: that of the command line's main thread.
const STACK_BYTES: usize = 8 << 20;

/// The most distinct findings a campaign that keeps going collects.
const MOST_FINDINGS: usize = 16;

/// What to run.
#[derive(Debug, Clone)]
pub struct Plan {
    pub seed: u64,
    /// Executions `first .. first + executions`.
    pub first: u64,
    pub executions: u64,
    /// Where inputs of findings (and the one being executed) are saved.
    pub findings: PathBuf,
    /// Collect distinct findings rather than stop at the first.
    pub keep_going: bool,
    /// Print a line on standard error this often.
    pub progress: Option<Duration>,
    /// CPU time after which an execution is reported as hung ([`HANG_CPU`]).
    pub hang_after: Duration,
    /// The most work an execution may do ([`Work::LIMIT`]).
    pub work: Work,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    Panic,
    Check,
    Work,
    Memory,
    Hang,
}

impl Kind {
    pub fn name(self) -> &'static str {
        match self {
            Kind::Panic => "panic",
            Kind::Check => "check",
            Kind::Work => "work",
            Kind::Memory => "memory",
            Kind::Hang => "hang",
        }
    }
}

#[derive(Debug, Clone)]
pub struct Finding {
    pub kind: Kind,
    pub execution: u64,
    pub message: String,
    /// The input, saved.
    pub saved: PathBuf,
}

/// What a campaign did.
#[derive(Debug, Clone, Default)]
pub struct Report {
    pub target: &'static str,
    pub seed: u64,
    pub executions: u64,
    pub seconds: f64,
    pub accepted: u64,
    pub refused: u64,
    /// The slowest execution: its number and CPU time.
    pub slowest: (u64, Duration),
    /// The most heap one execution held, and the largest single request.
    pub peak_bytes: u64,
    pub largest_request_bytes: u64,
    /// The most allocations one execution made, and the most bytes one asked for in all: the
    /// figures [`Work`] bounds.
    pub most_allocations: u64,
    pub most_allocated_bytes: u64,
    pub findings: Vec<Finding>,
}

impl Report {
    pub fn executions_per_second(&self) -> f64 {
        self.executions as f64 / self.seconds.max(1e-9)
    }

    pub fn summary(&self) -> String {
        format!(
            "{}: {} executions in {:.1} s ({:.0}/s), seed {}; {} accepted, {} refused; slowest {:.1} ms (execution {}), most heap {:.1} MiB, largest request {:.1} MiB, most allocations {} ({:.1} MiB in all; at most {} and {:.0} MiB); {} finding(s)",
            self.target,
            self.executions,
            self.seconds,
            self.executions_per_second(),
            self.seed,
            self.accepted,
            self.refused,
            self.slowest.1.as_secs_f64() * 1e3,
            self.slowest.0,
            self.peak_bytes as f64 / (1 << 20) as f64,
            self.largest_request_bytes as f64 / (1 << 20) as f64,
            self.most_allocations,
            self.most_allocated_bytes as f64 / (1 << 20) as f64,
            Work::LIMIT.allocations,
            Work::LIMIT.allocated_bytes as f64 / (1 << 20) as f64,
            self.findings.len()
        )
    }
}

thread_local! {
    /// Whether this thread is running a target (its panics are findings, not reports).
    static IN_TARGET: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    /// The last panic of a target on this thread: its message and place.
    static PANIC: RefCell<Option<String>> = const { RefCell::new(None) };
}

/// Executions under way in this process.
static RUNNING: AtomicUsize = AtomicUsize::new(0);
/// The first panic of a thread without a name (a worker of the library's thread pool) while
/// an execution was under way: the target's, resumed in its own thread.
static WORKER_PANIC: Mutex<Option<String>> = Mutex::new(None);

/// Installs, once, a panic hook that keeps a target's panic for its finding (on its thread, or
/// on a worker thread it handed work to) and leaves every other panic to the hook before it.
fn install_panic_hook() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            let own = IN_TARGET.with(std::cell::Cell::get);
            let worker =
                RUNNING.load(Ordering::SeqCst) > 0 && std::thread::current().name().is_none();
            if !own && !worker {
                previous(info);
                return;
            }
            let place = info
                .location()
                .map_or(String::new(), |l| format!(" at {}:{}", l.file(), l.line()));
            let payload = info
                .payload()
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| info.payload().downcast_ref::<String>().cloned())
                .unwrap_or_default();
            let message = format!(
                "panicked{place}{}: {}",
                library_frame(),
                volmap::error::excerpt(&payload)
            );
            if own {
                PANIC.with(|p| *p.borrow_mut() = Some(message));
            } else {
                let mut slot = WORKER_PANIC.lock().unwrap_or_else(|p| p.into_inner());
                slot.get_or_insert(message);
            }
        }));
    });
}

/// ` in FUNCTION`: the innermost function of volmap on the stack where a panic was raised (its
/// place may be in the standard library, as a capacity overflow's is).
fn library_frame() -> String {
    let trace = std::backtrace::Backtrace::force_capture().to_string();
    trace
        .lines()
        .map(str::trim)
        .filter_map(|l| l.split_once(": ").map(|(_, f)| f))
        .find(|f| f.starts_with("volmap::"))
        .map_or(String::new(), |f| format!(" in {f}"))
}

/// The material of a target's inputs: its corpus and dictionary.
pub struct Prepared {
    pub corpus: Vec<Vec<u8>>,
    pub dictionary: Vec<Vec<u8>>,
}

impl Prepared {
    pub fn of(target: &Target) -> Result<Prepared, String> {
        let corpus = super::corpus::load(target.name).map_err(|e| {
            format!(
                "{}: cannot read the corpus {}: {e}",
                target.name,
                super::corpus::folder(target.name).display()
            )
        })?;
        if corpus.is_empty() {
            return Err(format!("{}: the corpus is empty", target.name));
        }
        let dictionary = mutate::dictionary(&corpus, target.words);
        Ok(Prepared { corpus, dictionary })
    }

    pub fn material(&self, target: &Target) -> Material<'_> {
        Material {
            corpus: &self.corpus,
            dictionary: &self.dictionary,
            grammar: target.grammar,
        }
    }
}

/// The input of execution `execution` of seed `seed`.
pub fn input_at(target: &Target, prepared: &Prepared, seed: u64, execution: u64) -> Vec<u8> {
    let mut rng = Rng::for_execution(seed, execution);
    mutate::input(&prepared.material(target), &mut rng)
}

/// One execution and what it cost.
pub struct Executed {
    /// The verdict, or the panic's message.
    pub result: Result<Verdict, String>,
    pub cpu: Duration,
    pub usage: Usage,
}

/// Runs `input` through `target` once, catching a panic.
pub fn execute(target: &Target, cx: &mut Context, input: &[u8], clock: &ThreadClock) -> Executed {
    install_panic_hook();
    let start = clock.now_ns();
    RUNNING.fetch_add(1, Ordering::SeqCst);
    watch::begin();
    IN_TARGET.with(|t| t.set(true));
    let result = catch_unwind(AssertUnwindSafe(|| (target.run)(cx, input)));
    IN_TARGET.with(|t| t.set(false));
    let usage = watch::end();
    RUNNING.fetch_sub(1, Ordering::SeqCst);
    let cpu = Duration::from_nanos(clock.now_ns().saturating_sub(start));
    let worker = WORKER_PANIC
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .take();
    let own = PANIC.with(|p| p.borrow_mut().take());
    let result = result.map_err(|_| own.or(worker).unwrap_or_else(|| "panicked".to_string()));
    Executed { result, cpu, usage }
}

/// The findings of one execution, whose work is bounded by `work`.
pub fn judge(executed: &Executed, work: Work) -> Vec<(Kind, String)> {
    let mut out = Vec::new();
    match &executed.result {
        Err(panic) => out.push((Kind::Panic, panic.clone())),
        Ok(Err(check)) => out.push((Kind::Check, check.clone())),
        Ok(Ok(_)) => {}
    }
    let Usage {
        peak_bytes,
        largest_request_bytes,
        allocations,
        allocated_bytes,
    } = executed.usage;
    if allocations > work.allocations || allocated_bytes > work.allocated_bytes {
        out.push((
            Kind::Work,
            format!(
                "made {allocations} allocations asking for {allocated_bytes} bytes in all (at most {} and {} bytes), in {:.2} s of CPU time",
                work.allocations,
                work.allocated_bytes,
                executed.cpu.as_secs_f64()
            ),
        ));
    }
    if peak_bytes > MEMORY_LIMIT_BYTES || largest_request_bytes > MEMORY_LIMIT_BYTES {
        out.push((
            Kind::Memory,
            format!(
                "held {peak_bytes} bytes of heap, largest request {largest_request_bytes} bytes (at most 1 GiB)"
            ),
        ));
    }
    out
}

/// The file the input being executed is kept in, so that an execution that stops the process
/// (a refused allocation, a stack overflow) leaves it behind.
struct Slot {
    path: PathBuf,
    file: File,
}

impl Slot {
    fn create(path: PathBuf) -> std::io::Result<Slot> {
        let file = File::options()
            .create(true)
            .truncate(true)
            .read(true)
            .write(true)
            .open(&path)?;
        Ok(Slot { path, file })
    }

    fn keep(&self, input: &[u8]) {
        #[cfg(unix)]
        {
            use std::os::unix::fs::FileExt;
            let _ = self.file.write_all_at(input, 0);
        }
        #[cfg(not(unix))]
        {
            use std::io::{Seek, Write};
            let mut file = &self.file;
            let _ = file.seek(std::io::SeekFrom::Start(0));
            let _ = file.write_all(input);
        }
        let _ = self.file.set_len(input.len() as u64);
    }
}

/// Saves `input` as a finding's file.
fn save(
    findings: &Path,
    target: &str,
    kind: Kind,
    seed: u64,
    execution: u64,
    input: &[u8],
) -> PathBuf {
    let path = findings.join(format!(
        "{target}-{}-seed{seed}-execution{execution}.bin",
        kind.name()
    ));
    if let Err(e) = std::fs::write(&path, input) {
        eprintln!("fuzz: cannot save {}: {e}", path.display());
    }
    path
}

/// What the watchdog sees of the execution under way.
#[derive(Default)]
struct Shared {
    execution: AtomicU64,
    running: AtomicBool,
    started_cpu_ns: AtomicU64,
    started_wall_ns: AtomicU64,
    done: AtomicBool,
    clock: Mutex<Option<ThreadClock>>,
}

/// A key that tells findings apart: the kind and the place of a panic, or the message without
/// its numbers.
fn key(kind: Kind, message: &str) -> String {
    let text: String = message
        .chars()
        .filter(|c| !c.is_ascii_digit())
        .take(80)
        .collect();
    format!("{}:{text}", kind.name())
}

/// Runs the campaign `plan` of `target` on a thread of its own, with a watchdog on this one.
pub fn run(target: &'static Target, plan: &Plan) -> Result<Report, String> {
    if !watch::allocator_installed() {
        return Err("the counting allocator (watch::CountingAllocator) is not this binary's global allocator: a campaign could not see large allocations".into());
    }
    let prepared = Prepared::of(target)?;
    std::fs::create_dir_all(&plan.findings)
        .map_err(|e| format!("cannot create {}: {e}", plan.findings.display()))?;
    let slot_path = plan.findings.join(format!(
        "{}-current-{}.bin",
        target.name,
        std::process::id()
    ));
    let slot = Slot::create(slot_path.clone())
        .map_err(|e| format!("cannot create {}: {e}", slot_path.display()))?;
    let shared = Arc::new(Shared::default());
    let report = Arc::new(Mutex::new(Report {
        target: target.name,
        seed: plan.seed,
        ..Report::default()
    }));
    let begun = Instant::now();
    let worker = {
        let (shared, report, plan) = (shared.clone(), report.clone(), plan.clone());
        std::thread::Builder::new()
            .name(format!("fuzz-{}", target.name))
            .stack_size(STACK_BYTES)
            .spawn(move || {
                let result = work(target, &prepared, &plan, &slot, &shared, &report, begun);
                shared.done.store(true, Ordering::SeqCst);
                result
            })
            .map_err(|e| format!("cannot start the campaign's thread: {e}"))?
    };
    loop {
        std::thread::sleep(Duration::from_millis(50));
        if shared.done.load(Ordering::SeqCst) {
            break;
        }
        if !shared.running.load(Ordering::SeqCst) {
            continue;
        }
        let clock = *shared.clock.lock().unwrap_or_else(|p| p.into_inner());
        let Some(clock) = clock else { continue };
        let cpu = clock
            .now_ns()
            .saturating_sub(shared.started_cpu_ns.load(Ordering::SeqCst));
        let wall = (begun.elapsed().as_nanos() as u64)
            .saturating_sub(shared.started_wall_ns.load(Ordering::SeqCst));
        if cpu > plan.hang_after.as_nanos() as u64
            || wall > (plan.hang_after * HANG_WALL_FACTOR).as_nanos() as u64
        {
            let execution = shared.execution.load(Ordering::SeqCst);
            let input = std::fs::read(&slot_path).unwrap_or_default();
            let saved = save(
                &plan.findings,
                target.name,
                Kind::Hang,
                plan.seed,
                execution,
                &input,
            );
            let mut report = report.lock().unwrap_or_else(|p| p.into_inner()).clone();
            report.seconds = begun.elapsed().as_secs_f64();
            report.findings.push(Finding {
                kind: Kind::Hang,
                execution,
                message: format!(
                    "still running after {:.1} s of CPU time and {:.1} s",
                    cpu as f64 * 1e-9,
                    wall as f64 * 1e-9
                ),
                saved,
            });
            // The thread is left running: nothing can stop it from outside.
            return Ok(report);
        }
    }
    worker
        .join()
        .map_err(|_| "the campaign's thread panicked outside a target".to_string())??;
    let _ = std::fs::remove_file(&slot_path);
    let mut report = report.lock().unwrap_or_else(|p| p.into_inner()).clone();
    report.seconds = begun.elapsed().as_secs_f64();
    Ok(report)
}

/// The campaign's executions, on its thread.
fn work(
    target: &'static Target,
    prepared: &Prepared,
    plan: &Plan,
    slot: &Slot,
    shared: &Shared,
    report: &Mutex<Report>,
    begun: Instant,
) -> Result<(), String> {
    let clock = ThreadClock::current();
    *shared.clock.lock().unwrap_or_else(|p| p.into_inner()) = Some(clock);
    let slot_name: &'static str = Box::leak(slot.path.display().to_string().into_boxed_str());
    watch::describe_thread(target.name, slot_name);
    single_threaded(|| campaign(target, prepared, plan, slot, shared, report, begun, clock))
}

/// Runs `f` with the library's thread pool made of this thread alone: what a target hands to
/// the pool runs here, where its heap is counted and its panics are the target's, and no
/// waiting on other threads adds to its time.
pub fn single_threaded<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    match rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .use_current_thread()
        .build()
    {
        Ok(pool) => pool.install(f),
        Err(_) => f(),
    }
}

/// The executions of [`work`].
#[allow(clippy::too_many_arguments)]
fn campaign(
    target: &'static Target,
    prepared: &Prepared,
    plan: &Plan,
    slot: &Slot,
    shared: &Shared,
    report: &Mutex<Report>,
    begun: Instant,
    clock: ThreadClock,
) -> Result<(), String> {
    let mut cx = Context::new().map_err(|e| format!("cannot make a scratch folder: {e}"))?;
    let material = prepared.material(target);
    let mut seen: Vec<String> = Vec::new();
    let mut last_progress = Instant::now();
    for execution in plan.first..plan.first + plan.executions {
        let mut rng = Rng::for_execution(plan.seed, execution);
        let input = mutate::input(&material, &mut rng);
        slot.keep(&input);
        shared.execution.store(execution, Ordering::SeqCst);
        shared
            .started_wall_ns
            .store(begun.elapsed().as_nanos() as u64, Ordering::SeqCst);
        shared
            .started_cpu_ns
            .store(clock.now_ns(), Ordering::SeqCst);
        shared.running.store(true, Ordering::SeqCst);
        let executed = execute(target, &mut cx, &input, &clock);
        shared.running.store(false, Ordering::SeqCst);
        let findings = judge(&executed, plan.work);
        let mut r = report.lock().unwrap_or_else(|p| p.into_inner());
        r.executions += 1;
        match &executed.result {
            Ok(Ok(Outcome::Accepted)) => r.accepted += 1,
            Ok(Ok(Outcome::Refused(_))) => r.refused += 1,
            _ => {}
        }
        if executed.cpu > r.slowest.1 {
            r.slowest = (execution, executed.cpu);
        }
        r.peak_bytes = r.peak_bytes.max(executed.usage.peak_bytes);
        r.largest_request_bytes = r
            .largest_request_bytes
            .max(executed.usage.largest_request_bytes);
        r.most_allocations = r.most_allocations.max(executed.usage.allocations);
        r.most_allocated_bytes = r.most_allocated_bytes.max(executed.usage.allocated_bytes);
        for (kind, message) in findings {
            let k = key(kind, &message);
            if seen.contains(&k) {
                continue;
            }
            seen.push(k);
            let saved = save(
                &plan.findings,
                target.name,
                kind,
                plan.seed,
                execution,
                &input,
            );
            eprintln!(
                "fuzz: FINDING ({}) in {}, seed {} execution {}: {message}\n  input saved as {}",
                kind.name(),
                target.name,
                plan.seed,
                execution,
                saved.display()
            );
            r.findings.push(Finding {
                kind,
                execution,
                message,
                saved,
            });
        }
        if !r.findings.is_empty() && (!plan.keep_going || r.findings.len() >= MOST_FINDINGS) {
            break;
        }
        if let Some(every) = plan.progress {
            if last_progress.elapsed() >= every {
                last_progress = Instant::now();
                let seconds = begun.elapsed().as_secs_f64();
                eprintln!(
                    "fuzz: {}: {} executions, {:.0}/s, {:.0}% accepted, {} finding(s)",
                    target.name,
                    r.executions,
                    r.executions as f64 / seconds,
                    100.0 * r.accepted as f64 / r.executions as f64,
                    r.findings.len()
                );
            }
        }
    }
    Ok(())
}
