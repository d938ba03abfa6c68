//! The report of `volmap bench` as the table it prints.

use super::{BenchReport, PathResult, StageShares};
use crate::report::numbers::{percent, quantity};

/// The report as the table `volmap bench` prints: per path the median rate with the slowest and
/// fastest run, the ratio to the reference, the fractions of the ceilings; under each map the
/// share of each stage and the file's size.
pub fn table(report: &BenchReport) -> String {
    let mut out = format!(
        "volmap bench, {}\n  adapter  {}\n  CPU      {} ({} threads)\n  runs     {} per path, medians (slowest–fastest run); GPU kernels warmed up {} s first\n",
        report.date,
        report
            .adapter
            .as_deref()
            .unwrap_or("none (GPU paths left out)"),
        report.cpu,
        report.threads,
        report.runs,
        quantity(report.warm_up_s),
    );
    for m in &report.machines {
        out.push_str(&format!(
            "\n{} ({}), grid {}x{}x{}{}; disk ceiling {} MB/s\n  {:<52} {:>10} {:>19} {:>11} {:>8} {:>8}\n",
            m.machine,
            m.chain,
            m.grid[0],
            m.grid[1],
            m.grid[2],
            m.kernel_timing
                .as_ref()
                .map_or(String::new(), |t| format!(", GPU kernels timed by {t}")),
            quantity(m.disk_mb_per_s),
            "path",
            "Mpts/s",
            "(slowest–fastest)",
            "× reference",
            "ceiling",
            "disk"
        ));
        for p in &m.paths {
            out.push_str(&row(p));
        }
        if m.paths.iter().any(|p| p.path.contains("Monte Carlo")) {
            out.push_str(
                "  Monte Carlo rows count machine-points (machines × grid points), each machine's statistics reduced where it is computed\n",
            );
        }
        if m.paths.iter().any(|p| p.path.contains("map uncertainty")) {
            out.push_str(
                "  map uncertainty rows count grid points of the whole uncertainty (every quantity's or draw's maps, summed where they are computed), nothing written\n",
            );
        }
        if let Some(passes) = m.uncertainty_passes_per_quantity {
            out.push_str(&format!(
                "  first order on the GPU: {} kernel passes' time per uncertain quantity (two maps each, central differences)\n",
                quantity(passes)
            ));
        }
        if !m.against_plain.is_empty() {
            let ratios: Vec<String> = m
                .against_plain
                .iter()
                .map(|r| format!("{} {}×", r.path, quantity(r.ratio)))
                .collect();
            out.push_str(&format!(
                "  against the same machine with plain tables (errors of other axes made errors of the axis's own position): {}\n",
                ratios.join("; ")
            ));
        }
        if let (Some(kernel), Some(ceiling)) = (&m.kernel_tiling, &m.ceiling_tiling) {
            out.push_str(&format!(
                "  tilings: GPU kernel {kernel}; ceiling (the fastest write-only) {ceiling}\n"
            ));
        }
    }
    out
}

fn row(p: &PathResult) -> String {
    let part = |f: Option<f64>| f.map_or(String::new(), |f| percent(f * 100.0));
    let mut line = format!(
        "  {:<52} {:>10} {:>19} {:>11} {:>8} {:>8}\n",
        p.path,
        quantity(p.mpts_per_s),
        format!(
            "({}–{})",
            quantity(p.mpts_per_s_min),
            quantity(p.mpts_per_s_max)
        ),
        quantity(p.ratio_to_reference),
        part(p.fraction_of_ceiling),
        part(p.fraction_of_disk)
    );
    if let Some(stages) = &p.stages {
        line.push_str(&format!("      stages {}", stage_text(stages)));
        if let Some(bytes) = p.file_bytes {
            line.push_str(&format!("; file {} MB", quantity(bytes as f64 / 1e6)));
        }
        line.push('\n');
    } else if let (Some(bytes), true) = (p.file_bytes, p.path.starts_with("compress")) {
        // 24 bytes a point uncompressed.
        line.push_str(&format!(
            "      {}× smaller than uncompressed\n",
            quantity((24 * p.points) as f64 / bytes.max(1) as f64)
        ));
    }
    line
}

/// The stage shares in words: `engine 40.0% (device 10.0%, readback 25.0%), hand-off 5.0%
/// (waiting 1.0%), compress 80.0%, write 20.0%, sync 3.0%`.
fn stage_text(s: &StageShares) -> String {
    let pc = |f: f64| percent(f * 100.0);
    let device = match (s.device, s.readback) {
        (Some(d), Some(r)) => format!(" (device {}, readback {})", pc(d), pc(r)),
        _ => String::new(),
    };
    format!(
        "engine {}{device}, hand-off {} (waiting {}), compress {}, write {}, sync {}",
        pc(s.engine),
        pc(s.handoff),
        pc(s.waiting),
        pc(s.compress),
        pc(s.write),
        pc(s.sync)
    )
}
