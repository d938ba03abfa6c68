//! `rrf-heightmap`: RepRapFirmware's height map, `heightmap.csv`, loaded by `G29 S1`
//! (RepRapFirmware's `HeightMap::SaveToFile`, `LoadFromFile`, `GetInterpolatedHeightError` in
//! `Grid.cpp`; `GridDefinition::ReadParameters`; `Move::BedTransform`; the limits in
//! `Configuration.h`).
//!
//! The file is the `v2` heading, the labels `axis0,axis1,min0,max0,min1,max1,radius,spacing0,
//! spacing1,num0,num1`, one line of them (`%.2f`) and `num1` rows of `num0` values (`%7.3f`, mm),
//! the first row at the least Y, the first value at the least X. The firmware takes the grid's
//! nodes at `min + i·spacing` (the maxima unused), interpolates bilinearly, holds the edge
//! values outside the grid (positions clamped to `[min, last − 0.01]`), and ADDS the height to
//! Z for every move: a positive value is a bed higher than nominal. A bare `0` is a point not
//! probed (the firmware fills it from a plane), so a probed zero must read `0.000`.

use crate::export::error::{read_error, ExportError};
use crate::export::fitting::{mean, Fitting, Structure};
use crate::export::format::{
    self, Control, Format, Layout, Limits, Nodes, Spec, TableInfo, WrittenFile,
};
use crate::model::inputs::Approach;
use crate::model::Command;

pub struct RrfHeightMap;

const FILE: &str = "heightmap.csv";
const HEADING: &str = "RepRapFirmware height map file v2";
const LABELS: &str = "axis0,axis1,min0,max0,min1,max1,radius,spacing0,spacing1,num0,num1";
/// `MaxGridProbePoints` of every board but the SAME70 ones (961 on a Duet 3 MB6HC/MB6XD).
const MAX_GRID_POINTS: usize = 441;
/// `MaxAxis0GridPoints`: points in one row along X.
const MAX_ROW_POINTS: usize = 41;
/// The firmware's clamp below the last node (`fEPSILON`), mm.
const EDGE_MM: f64 = 0.01;
/// Points along Z the height at a node is the mean of.
const Z_SAMPLES: usize = 21;

const SPEC: Spec = Spec {
    name: "rrf-heightmap",
    title: "RepRapFirmware (height map, G29 S1)",
    layout: Layout::Folder,
    limits: Limits {
        nodes: Nodes::Equidistant,
        min_points: 2,
        max_points: MAX_ROW_POINTS,
        min_spacing_mm: 0.1,
        default_points: 21,
        source: "RepRapFirmware's grid: 41 points a row (MaxAxis0GridPoints), 441 in all (MaxGridProbePoints; 961 on a Duet 3 MB6HC/MB6XD), spacing 0.1 mm or more",
    },
    structure: Structure::ZOfXY,
    holds: "one height a point of an X-Y grid, added to Z (bilinear between points, the edge held beyond): Z's correction as a function of X and Y, its mean over Z's travel; nothing of X's or Y's corrections, nor of how Z's varies with Z",
    uses_direction: false,
};

/// The grid as the firmware holds it after loading.
#[derive(Debug, Clone, PartialEq)]
struct HeightMap {
    mins: [f64; 2],
    spacings: [f64; 2],
    nums: [usize; 2],
    /// Row `j` (Y), column `i` (X) at `j·nums[0] + i`, mm.
    heights: Vec<f64>,
}

impl HeightMap {
    /// `GetInterpolatedHeightError`: bilinear, positions clamped to the grid.
    fn height(&self, x: f64, y: f64) -> f64 {
        let cell = |v: f64, d: usize| {
            let last = self.mins[d] + (self.nums[d] - 1) as f64 * self.spacings[d];
            let v = v.max(self.mins[d]).min(last - EDGE_MM);
            let f = (v - self.mins[d]) / self.spacings[d];
            let floor = f.floor().max(0.0);
            (floor as usize, f - floor)
        };
        let ((i, fx), (j, fy)) = (cell(x, 0), cell(y, 1));
        let at = |i: usize, j: usize| self.heights[j * self.nums[0] + i];
        at(i, j) * (1.0 - fx - fy + fx * fy)
            + at(i + 1, j) * (fx - fx * fy)
            + at(i, j + 1) * (fy - fx * fy)
            + at(i + 1, j + 1) * fx * fy
    }
}

/// `v` rounded up to the 0.01 mm the parameters are written in.
fn up_to_hundredths(v: f64) -> f64 {
    (v * 100.0 - 1e-6).ceil() / 100.0
}

/// A value as the firmware writes it (`%7.3f`), a zero with its decimals (a bare `0` would
/// read as a point not probed) and never `-0.000`.
fn value(v: f64) -> String {
    let text = format!("{v:7.3}");
    if text.trim() == "-0.000" {
        format!("{:7.3}", 0.0)
    } else {
        text
    }
}

impl Format for RrfHeightMap {
    fn spec(&self) -> &'static Spec {
        &SPEC
    }

    fn write(
        &self,
        fitting: &Fitting,
        points: Option<[usize; 3]>,
        spacing_mm: Option<f64>,
    ) -> Result<Vec<WrittenFile>, ExportError> {
        let [nx, ny, _] = points.unwrap_or([SPEC.limits.default_points; 3]);
        if nx * ny > MAX_GRID_POINTS {
            return Err(ExportError::TooManyPoints {
                format: SPEC.name,
                axis: format!(" over X and Y together ({nx} x {ny})"),
                points: (nx * ny).to_string(),
                max: MAX_GRID_POINTS,
                limits_from: SPEC.limits.source,
            });
        }
        let nums = [nx, ny];
        let mut mins = [0.0; 2];
        let mut spacings = [0.0; 2];
        for d in 0..2 {
            let [lo, hi] = fitting.ranges[d];
            if hi - lo < 1.0 {
                return Err(ExportError::Unrepresentable {
                    format: SPEC.name,
                    message: format!(
                        "a grid spans 1 mm or more; the travel along axis {d} spans {} mm",
                        hi - lo
                    ),
                });
            }
            mins[d] = (lo * 100.0).round() / 100.0;
            // The nodes from the start of the travel to its end or just beyond.
            spacings[d] = match spacing_mm {
                Some(s) => up_to_hundredths(s),
                None => up_to_hundredths((hi - mins[d]) / (nums[d] - 1) as f64),
            };
        }
        let node = |d: usize, i: usize| {
            let [lo, hi] = fitting.ranges[d];
            (mins[d] + i as f64 * spacings[d]).clamp(lo, hi)
        };
        let zs = fitting.travel(2, Z_SAMPLES);
        let mut heights = Vec::with_capacity(nx * ny);
        for j in 0..ny {
            for i in 0..nx {
                let targets: Vec<[f64; 3]> =
                    zs.iter().map(|&z| [node(0, i), node(1, j), z]).collect();
                let d = fitting.field().corrections(&targets)?;
                heights.push(mean(&d.iter().map(|v| v[2]).collect::<Vec<_>>()));
            }
        }
        let rounded: Vec<f64> = heights
            .iter()
            .map(|h| (h * 1000.0).round() / 1000.0)
            .collect();
        let (lowest, highest) = rounded
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), &h| (a.min(h), b.max(h)));
        let average = mean(&rounded);
        let deviation = (rounded.iter().map(|h| (h - average).powi(2)).sum::<f64>()
            / rounded.len() as f64)
            .sqrt();
        let mut text = format!(
            "{HEADING} generated by volmap, min error {lowest:.3}, max error {highest:.3}, mean {average:.3}, deviation {deviation:.3}\n{LABELS}\n"
        );
        let last = |d: usize| mins[d] + (nums[d] - 1) as f64 * spacings[d];
        text += &format!(
            "X,Y,{:.2},{:.2},{:.2},{:.2},-1.00,{:.2},{:.2},{nx},{ny}\n",
            mins[0],
            last(0),
            mins[1],
            last(1),
            spacings[0],
            spacings[1]
        );
        for row in rounded.chunks(nx) {
            text += &row.iter().map(|&h| value(h)).collect::<Vec<_>>().join(",");
            text += "\n";
        }
        Ok(vec![WrittenFile {
            name: FILE.into(),
            text,
        }])
    }

    fn read(
        &self,
        files: &[WrittenFile],
        _travel_mm: &[[f64; 2]; 3],
    ) -> Result<Box<dyn Control>, ExportError> {
        let file = files
            .iter()
            .find(|f| f.name == FILE)
            .ok_or_else(|| read_error(FILE, 0, "no such file"))?;
        Ok(Box::new(read_map(file)?))
    }
}

/// `LoadFromFile` and `ReadParameters`, for a rectangular X-Y grid.
fn read_map(file: &WrittenFile) -> Result<HeightMap, ExportError> {
    let name = &file.name;
    let mut lines = file.text.lines().enumerate().map(|(n, l)| (n + 1, l));
    let mut next = |what: &str| {
        lines
            .next()
            .ok_or_else(|| read_error(name, 0, format!("no {what}")))
    };
    let (n, heading) = next("heading")?;
    if !heading.starts_with(HEADING) {
        return Err(read_error(
            name,
            n,
            format!("the heading must start `{HEADING}`"),
        ));
    }
    let (n, labels) = next("labels")?;
    if !labels.starts_with(LABELS) {
        return Err(read_error(name, n, format!("the labels must read `{LABELS}` (volmap reads the v2 grid of RepRapFirmware 3.3 and later)")));
    }
    let (n, line) = next("grid parameters")?;
    // Each field is followed at once by a comma, but the last.
    let fields: Vec<&str> = line.split(',').collect();
    if fields.len() < 11 {
        return Err(read_error(name, n, "the grid needs 11 parameters"));
    }
    if fields[0] != "X" || fields[1] != "Y" {
        return Err(read_error(
            name,
            n,
            format!(
                "axes `{}`, `{}`: volmap reads an X-Y grid",
                fields[0], fields[1]
            ),
        ));
    }
    let real = |k: usize| -> Result<f64, ExportError> {
        let f = fields[k].trim_start();
        f.parse::<f32>().map(f64::from).map_err(|_| {
            read_error(
                name,
                n,
                format!("parameter {} `{}` is no number", k + 1, fields[k]),
            )
        })
    };
    let whole = |k: usize| -> Result<usize, ExportError> {
        let f = fields[k].trim_start();
        let digits: String = f.chars().take_while(|c| c.is_ascii_digit()).collect();
        if k < 10 && digits.len() != f.len() || digits.is_empty() {
            return Err(read_error(
                name,
                n,
                format!("parameter {} `{}` is no whole number", k + 1, fields[k]),
            ));
        }
        digits
            .parse()
            .map_err(|_| read_error(name, n, format!("parameter {} is too large", k + 1)))
    };
    let (min0, max0, min1, max1) = (real(2)?, real(3)?, real(4)?, real(5)?);
    let radius = real(6)?;
    let spacings = [real(7)?, real(8)?];
    let nums = [whole(9)?, whole(10)?];
    let bad = |why: String| Err(read_error(name, n, why));
    if max0 - min0 < 1.0 || max1 - min1 < 1.0 {
        return bad("each axis's range must be 1 mm or more".into());
    }
    if spacings.iter().any(|&s| s < 0.1) {
        return bad("each spacing must be 0.1 mm or more".into());
    }
    if radius >= 0.0 {
        return bad(format!(
            "radius {radius}: volmap reads a rectangular grid (radius -1)"
        ));
    }
    if nums[0] * nums[1] > MAX_GRID_POINTS
        || nums[0] > MAX_ROW_POINTS
        || nums.iter().any(|&k| k < 2)
    {
        return bad(format!(
            "{} x {} points: 2 to {MAX_ROW_POINTS} a row, at most {MAX_GRID_POINTS} in all",
            nums[0], nums[1]
        ));
    }
    let mut heights = Vec::with_capacity(nums[0] * nums[1]);
    for _ in 0..nums[1] {
        let (n, row) = next("more rows: the grid has fewer rows than num1")?;
        if row.is_empty() {
            return Err(read_error(
                name,
                n,
                "an empty line where a row of heights belongs",
            ));
        }
        if row.len() > MAX_ROW_POINTS * 8 {
            return Err(read_error(
                name,
                n,
                "the row is longer than the firmware's line buffer",
            ));
        }
        let mut rest = row;
        for column in 1..=nums[0] {
            rest = rest.trim_start_matches([' ', '\t']);
            let end = rest.find(',').unwrap_or(rest.len());
            let cell = &rest[..end];
            if cell == "0" {
                return Err(read_error(
                    name,
                    n,
                    format!("column {column}: a bare 0 is a point not probed (write 0.000)"),
                ));
            }
            let h: f32 = cell.parse().map_err(|_| {
                read_error(
                    name,
                    n,
                    format!("column {column}: number expected, `{cell}`"),
                )
            })?;
            heights.push(h as f64);
            if end == rest.len() && column < nums[0] {
                return Err(read_error(
                    name,
                    n,
                    format!("{column} heights where the row needs {}", nums[0]),
                ));
            }
            rest = &rest[(end + 1).min(rest.len())..];
        }
    }
    Ok(HeightMap {
        mins: [min0, min1],
        spacings,
        nums,
        heights,
    })
}

impl Control for HeightMap {
    fn command(&self, target: &Command, _approach: &[Approach; 6]) -> Command {
        let mut c = *target;
        c[2] += self.height(target[0], target[1]);
        c
    }

    fn tables(&self) -> Vec<TableInfo> {
        vec![TableInfo {
            name: "height map".into(),
            size: format!(
                "{} x {} points from X {:.2} Y {:.2}, spacing {:.2} x {:.2} mm",
                self.nums[0],
                self.nums[1],
                self.mins[0],
                self.mins[1],
                self.spacings[0],
                self.spacings[1]
            ),
            points: self.nums[0].max(self.nums[1]),
            corrects: format::component(2),
        }]
    }
}
