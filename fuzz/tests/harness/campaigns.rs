//! Short fuzzing campaigns of every parser and reader, run on every change (docs/testing.md, "Fuzzing"):
//! the harness of this crate (the one the long campaigns run), a few thousand executions per
//! target from a fixed seed (`VOLMAP_FUZZ_SEED` picks another), each failing the test with the
//! finding and the saved input; the corpus read as it is; and the harness's own checks (a
//! panic, a broken check, an execution beyond its counted work, a large allocation and a hang are
//! each found, a slow execution that ends within its counts is not, and execution N of a seed is
//! always the same input).

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use volmap_fuzz::campaign::{self, Executed, Kind, Plan, Report, Work};
use volmap_fuzz::material::Grammar;
use volmap_fuzz::targets::{self, Context, Outcome, Target, Verdict, TARGETS};
use volmap_fuzz::watch::{self, ThreadClock, Usage};

fn plan(executions: u64) -> Plan {
    let seed = std::env::var("VOLMAP_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(19);
    Plan {
        seed,
        first: 0,
        executions,
        findings: volmap_fuzz::findings_folder(),
        keep_going: false,
        progress: None,
        hang_after: campaign::HANG_CPU,
        work: Work::LIMIT,
    }
}

fn run(target: &'static Target, plan: &Plan) -> Report {
    campaign::run(target, plan).unwrap_or_else(|e| panic!("{}: {e}", target.name))
}

/// A short campaign of `name`: no finding, and some inputs accepted (else the corpus or the
/// mutations have gone wrong and the campaign tests nothing past the first error).
fn short_campaign(name: &str, executions: u64) {
    let target = targets::find(name).expect("a target");
    let plan = plan(executions);
    let report = run(target, &plan);
    let findings: Vec<String> = report
        .findings
        .iter()
        .map(|f| {
            format!(
                "{} at execution {}: {}\n  input: {}\n  again: cargo run --release -p volmap-fuzz -- --target {name} --replay {}",
                f.kind.name(),
                f.execution,
                f.message,
                f.saved.display(),
                f.saved.display()
            )
        })
        .collect();
    assert!(
        findings.is_empty(),
        "{}\n{}",
        report.summary(),
        findings.join("\n")
    );
    assert_eq!(report.executions, executions, "{}", report.summary());
    assert!(
        report.accepted > 0,
        "no input accepted: {}",
        report.summary()
    );
    assert!(report.refused > 0, "no input refused: {}", report.summary());
}

#[test]
fn machine() {
    short_campaign("machine", 3000);
}

#[test]
fn tolerance() {
    short_campaign("tolerance", 3000);
}

#[test]
fn part() {
    short_campaign("part", 1000);
}

#[test]
fn stl() {
    short_campaign("stl", 5000);
}

#[test]
fn points() {
    short_campaign("points", 5000);
}

#[test]
fn measured() {
    short_campaign("measured", 2000);
}

#[test]
fn fit() {
    short_campaign("fit", 1000);
}

#[test]
fn interferometer() {
    short_campaign("interferometer", 3000);
}

#[test]
fn gcode() {
    short_campaign("gcode", 2000);
}

#[test]
fn offsets() {
    short_campaign("offsets", 5000);
}

#[test]
fn field() {
    short_campaign("field", 3000);
}

/// Each execution builds and scans a file of 4 MB, five times over: fewer of them.
#[test]
fn toml_size() {
    short_campaign("toml-size", 150);
}

/// Each execution builds and counts a program of 5 MB: fewer of them.
#[test]
fn nc_size() {
    short_campaign("nc-size", 150);
}

/// Every seed of every corpus is read as it is: a corpus of files the readers refuse would
/// test only their first error.
#[test]
fn every_seed_is_accepted() {
    campaign::single_threaded(every_seed_is_accepted_here);
}

fn every_seed_is_accepted_here() {
    let mut cx = Context::new().unwrap();
    let clock = ThreadClock::current();
    for target in TARGETS {
        let prepared = campaign::Prepared::of(target).unwrap();
        for (n, seed) in prepared.corpus.iter().enumerate() {
            let executed = campaign::execute(target, &mut cx, seed, &clock);
            assert!(
                matches!(executed.result, Ok(Ok(Outcome::Accepted))),
                "{}: seed {n} of {}: {:?}",
                target.name,
                prepared.corpus.len(),
                executed.result
            );
        }
    }
}

#[test]
fn execution_n_of_a_seed_is_always_the_same_input() {
    for target in TARGETS {
        let prepared = campaign::Prepared::of(target).unwrap();
        let inputs: Vec<Vec<u8>> = (0..50)
            .map(|n| campaign::input_at(target, &prepared, 7, n))
            .collect();
        for (n, input) in inputs.iter().enumerate() {
            assert_eq!(
                *input,
                campaign::input_at(target, &prepared, 7, n as u64),
                "{}",
                target.name
            );
        }
        let other: Vec<Vec<u8>> = (0..50)
            .map(|n| campaign::input_at(target, &prepared, 8, n))
            .collect();
        assert_ne!(inputs, other, "{}: another seed, other inputs", target.name);
        let distinct = {
            let mut i = inputs.clone();
            i.sort();
            i.dedup();
            i.len()
        };
        assert!(
            distinct > 25,
            "{}: {distinct} distinct inputs of 50",
            target.name
        );
    }
}

#[test]
fn inputs_of_several_files_split_at_their_marks() {
    let (main, files) =
        volmap_fuzz::corpus::split(b"a = 1\n#=== x.csv\nq,v\n0,1\n#=== ../up.csv\n#=== y.csv\r\nz");
    assert_eq!(main, b"a = 1\n");
    assert_eq!(
        files,
        vec![
            ("x.csv", &b"q,v\n0,1\n#=== ../up.csv\n"[..]),
            ("y.csv", &b"z"[..])
        ]
    );
    assert_eq!(
        volmap_fuzz::corpus::split(b"plain"),
        (&b"plain"[..], vec![])
    );
}

// The harness finds what it is for: each kind of finding from a target made to show it.

fn panics(_: &mut Context, input: &[u8]) -> Verdict {
    let index = input.len() + 1;
    Ok(Outcome::Refused(input[index].to_string()))
}

fn breaks_a_check(_: &mut Context, _: &[u8]) -> Verdict {
    Err("a check".into())
}

fn refuses_as_work(cx: &mut Context, _: &[u8]) -> Verdict {
    targets::refused(
        volmap::io::FileError::write(cx.scratch.path(), std::io::ErrorKind::Other.into()),
        &[],
    )
}

fn spins(_: &mut Context, _: &[u8]) -> Verdict {
    let clock = ThreadClock::current();
    let start = clock.now_ns();
    while clock.now_ns() - start < 1_200_000_000 {
        std::hint::spin_loop();
    }
    Ok(Outcome::Accepted)
}

/// A thousand and one small allocations, each freed at once.
fn allocates_often(_: &mut Context, _: &[u8]) -> Verdict {
    for i in 0..1001u32 {
        std::hint::black_box(Box::new(i));
    }
    Ok(Outcome::Accepted)
}

/// Blocks of 1 MiB asked for and freed until the bytes in all pass the limit: the heap held
/// stays at 1 MiB.
fn allocates_much_in_all(_: &mut Context, _: &[u8]) -> Verdict {
    for _ in 0..=watch::MOST_ALLOCATED_BYTES >> 20 {
        // Asked for, never touched: address space only.
        let block: Vec<u8> = Vec::with_capacity(1 << 20);
        std::hint::black_box(&block);
    }
    Ok(Outcome::Accepted)
}

fn allocates(_: &mut Context, _: &[u8]) -> Verdict {
    // Asked for, never touched: address space only.
    let big: Vec<u8> = Vec::with_capacity(1536 << 20);
    std::hint::black_box(&big);
    Ok(Outcome::Accepted)
}

static STOP_HANGING: AtomicBool = AtomicBool::new(false);

fn hangs(_: &mut Context, _: &[u8]) -> Verdict {
    while !STOP_HANGING.load(Ordering::SeqCst) {
        std::hint::spin_loop();
    }
    Ok(Outcome::Accepted)
}

const fn made_to(run: fn(&mut Context, &[u8]) -> Verdict) -> Target {
    Target {
        name: "stl",
        about: "",
        grammar: Grammar::Stl,
        words: &[],
        run,
    }
}

static PANICS: Target = made_to(panics);
static BREAKS: Target = made_to(breaks_a_check);
static AS_WORK: Target = made_to(refuses_as_work);
static SPINS: Target = made_to(spins);
static ALLOCATES: Target = made_to(allocates);
static ALLOCATES_OFTEN: Target = made_to(allocates_often);
static ALLOCATES_MUCH: Target = made_to(allocates_much_in_all);
static HANGS: Target = made_to(hangs);

fn first_finding(target: &'static Target, plan: &Plan) -> (Kind, String, Vec<u8>) {
    let report = run(target, plan);
    let f = report.findings.first().expect("a finding");
    assert_eq!(report.findings.len(), 1, "{:?}", report.findings);
    let saved = std::fs::read(&f.saved).unwrap();
    std::fs::remove_file(&f.saved).unwrap();
    (f.kind, f.message.clone(), saved)
}

#[test]
fn the_harness_finds_each_kind_of_failure_and_saves_its_input() {
    let stl = campaign::Prepared::of(&PANICS).unwrap();
    let plan = Plan {
        seed: 3,
        first: 5,
        ..plan(10)
    };
    let (kind, message, input) = first_finding(&PANICS, &plan);
    assert_eq!(kind, Kind::Panic);
    assert!(
        message.contains("campaigns.rs") && message.contains("index out of bounds"),
        "{message}"
    );
    assert_eq!(
        input,
        campaign::input_at(&PANICS, &stl, 3, 5),
        "the input saved is execution 5's"
    );

    let (kind, message, _) = first_finding(&BREAKS, &plan);
    assert_eq!((kind, message.as_str()), (Kind::Check, "a check"));
    let (kind, message, _) = first_finding(&AS_WORK, &plan);
    assert_eq!(kind, Kind::Check);
    assert!(message.contains("exit code 1"), "{message}");
    let (kind, _, _) = first_finding(&ALLOCATES, &plan);
    assert_eq!(kind, Kind::Memory);
    // Work is counted: a thousand and one allocations pass a limit of a thousand, and 16 GiB
    // asked for in all pass the real limit, however little heap is held at once.
    let (kind, message, _) = first_finding(
        &ALLOCATES_OFTEN,
        &Plan {
            work: Work {
                allocations: 1000,
                ..Work::LIMIT
            },
            ..plan.clone()
        },
    );
    assert_eq!(kind, Kind::Work, "{message}");
    assert!(message.starts_with("made 1001 allocations"), "{message}");
    let quiet = run(&ALLOCATES_OFTEN, &plan);
    assert_eq!(quiet.findings.len(), 0, "{:?}", quiet.findings);
    assert_eq!(quiet.most_allocations, 1001, "{}", quiet.summary());
    let (kind, message, _) = first_finding(
        &ALLOCATES_MUCH,
        &Plan {
            executions: 1,
            ..plan.clone()
        },
    );
    assert_eq!(kind, Kind::Work, "{message}");
    assert!(
        message.contains(&format!("at most {}", watch::MOST_ALLOCATIONS)),
        "{message}"
    );
    // A clock does not decide: 1.2 s of CPU time that ends within the counts is no finding.
    let slow = run(
        &SPINS,
        &Plan {
            executions: 1,
            ..plan.clone()
        },
    );
    assert_eq!(slow.findings.len(), 0, "{:?}", slow.findings);
    assert!(
        slow.slowest.1 > Duration::from_secs(1),
        "{}",
        slow.summary()
    );

    let hang_plan = Plan {
        executions: 1,
        hang_after: Duration::from_millis(300),
        ..plan
    };
    let (kind, _, _) = first_finding(&HANGS, &hang_plan);
    STOP_HANGING.store(true, Ordering::SeqCst);
    assert_eq!(kind, Kind::Hang);
}

/// The check of an execution's work, alone: over either count is a finding that reports both
/// figures, at the count is none, and CPU time is no part of it.
#[test]
fn work_beyond_either_count_is_a_finding_whatever_the_clock() {
    let limit = Work::LIMIT;
    let executed = |allocations: u64, allocated_bytes: u64, seconds: u64| Executed {
        result: Ok(Ok(Outcome::Accepted)),
        cpu: Duration::from_secs(seconds),
        usage: Usage {
            peak_bytes: 0,
            largest_request_bytes: 0,
            allocations,
            allocated_bytes,
        },
    };
    let at_limit = executed(limit.allocations, limit.allocated_bytes, 9);
    assert_eq!(campaign::judge(&at_limit, limit), vec![]);
    for (allocations, bytes) in [(limit.allocations + 1, 0), (0, limit.allocated_bytes + 1)] {
        let findings = campaign::judge(&executed(allocations, bytes, 0), limit);
        assert_eq!(findings.len(), 1, "{findings:?}");
        assert_eq!(findings[0].0, Kind::Work);
        assert!(
            findings[0].1.starts_with(&format!(
                "made {allocations} allocations asking for {bytes} bytes"
            )),
            "{}",
            findings[0].1
        );
    }
}

/// The allocator counts every allocation of the watched thread and the bytes each asks for,
/// from zero at each execution's start.
#[test]
fn the_allocator_counts_allocations_and_bytes() {
    for round in 0..2 {
        watch::begin();
        for i in 0..10u64 {
            std::hint::black_box(Vec::<u8>::with_capacity(100 + i as usize));
        }
        let usage = watch::end();
        assert_eq!(usage.allocations, 10, "round {round}: {usage:?}");
        assert_eq!(usage.allocated_bytes, 1045, "round {round}: {usage:?}");
    }
}
