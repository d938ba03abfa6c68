//! The uncertainty of VE from the standard uncertainties of the error values (docs/model.md,
//! "Uncertainty of the error values"): first order against values derived by hand from the chain,
//! and Monte Carlo against first order on every embedded machine.

use volmap::io::embedded::EMBEDDED;
use volmap::model::inputs::Inputs;
use volmap::model::{Command, Machine};
use volmap::reference::Propagation;

/// A 3-axis machine with an X-Y table under a Z head (FYXFZ), tool 100 mm below the spindle,
/// with `errors` added to the file (axis sections and others).
fn vmc(x: &str, y: &str, rest: &str) -> Machine {
    let text = format!(
        "name = \"u\"\nchain = \"FYXFZ\"\n[tool]\noffset = [0.0, 0.0, -100.0]\n\
         [axes.X]\nrange = [0.0, 500.0]\n{x}\n[axes.Y]\nrange = [0.0, 400.0]\n{y}\n\
         [axes.Z]\nrange = [0.0, 300.0]\n{rest}\n"
    );
    Machine::from_toml(&text, "u.toml", None).unwrap()
}

fn u_at(machine: &Machine, command: Command) -> [f64; 6] {
    Propagation::new(machine).first_order(&command)
}

fn close(got: f64, want: f64, relative: f64) -> bool {
    (got - want).abs() <= relative * want.abs() + 1e-18
}

/// On FYXFZ the tip is `x·x̂ + Rz(EC0Y)·(y·ŷ + (z + tool)·ẑ)`: `VE.x = −y·sin EC0Y`, so to first
/// order `u(VE.x) = |y|·cos(EC0Y)·u`, `u(VE.y) = |y|·sin(EC0Y)·u`, `u(VE.z) = 0`, and the tool
/// turns by EC0Y about z: `u(OE.z) = u`.
#[test]
fn a_squareness_with_u_gives_y_times_u() {
    let (c, u): (f64, f64) = (1.8e-5, 2.0e-6);
    let machine = vmc("", &format!("EC0Y = {{ value = {c:e}, u = {u:e} }}"), "");
    assert_eq!(machine.uncertainty.values.len(), 1);
    assert_eq!(machine.uncertainty.values[0].name, "axes.Y.EC0Y");
    for y in [0.0, 150.0, 400.0] {
        let got = u_at(&machine, [120.0, y, 80.0, 0.0, 0.0, 0.0]);
        assert!(close(got[0], y * c.cos() * u, 1e-6), "y {y}: {got:?}");
        assert!(close(got[1], y * c.sin() * u, 1e-3), "y {y}: {got:?}");
        assert!(got[2].abs() < 1e-15, "y {y}: {got:?}");
        assert!(close(got[5], u, 1e-6), "y {y}: {got:?}");
    }
}

/// `VE.x = EXX(x)` on FYXFZ (X's translation error adds to the tip as it stands): the linear
/// table's uncertainty between nodes `i` and `i+1` at `t` is `sqrt((1−t)²u_i² + t²u_{i+1}²)`.
#[test]
fn a_linear_table_interpolates_its_nodes_uncertainties() {
    let machine = vmc(
        "EXX = { table = [[0, 0.0], [100, 0.01], [300, 0.02]], u = [1e-3, 2e-3, 3e-3] }",
        "",
        "",
    );
    let cases = [
        (50.0, (0.25f64 * 1e-6 + 0.25 * 4e-6).sqrt()),
        (100.0, 2e-3),
        (150.0, (0.5625f64 * 4e-6 + 0.0625 * 9e-6).sqrt()),
        (450.0, 3e-3),
    ];
    for (x, want) in cases {
        let got = u_at(&machine, [x, 200.0, 100.0, 0.0, 0.0, 0.0]);
        assert!(close(got[0], want, 1e-9), "x {x}: {} vs {want}", got[0]);
        assert!(got[1].abs() < 1e-15 && got[2].abs() < 1e-15, "{got:?}");
    }
}

/// `u_scale` adds `s·(q − q0)` at every node, one `s` for the table: between the first and the
/// last node the correlated part is `u_scale·(x − q0)`; before the first node it is zero, past
/// the last the end value holds. With per-node u beside it the two add in quadrature.
#[test]
fn a_tables_scale_part_grows_from_its_first_node() {
    let scale = vmc(
        "EXX = { table = [[100, 0.0], [200, 0.01], [400, 0.02]], u_scale = 1e-5 }",
        "",
        "",
    );
    for (x, want) in [
        (50.0, 0.0),
        (100.0, 0.0),
        (250.0, 1.5e-3),
        (400.0, 3e-3),
        (500.0, 3e-3),
    ] {
        let got = u_at(&scale, [x, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert!(close(got[0], want, 1e-9), "x {x}: {} vs {want}", got[0]);
    }
    let both = vmc(
        "EXX = { table = [[100, 0.0], [200, 0.01], [400, 0.02]], u = [1e-3, 1e-3, 2e-3], u_scale = 1e-5 }",
        "",
        "",
    );
    // x = 300: t = 0.5 between 200 and 400, scale part 2e-3.
    let want = (0.25f64 * 1e-6 + 0.25 * 4e-6 + 4e-6).sqrt();
    let got = u_at(&both, [300.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    assert!(close(got[0], want, 1e-9), "{} vs {want}", got[0]);
}

/// `EX0X` and `EXS` both add to VE.x as they stand (the axes and the spindle are not turned):
/// `u²(VE.x) = u² + u² + 2·cov`: a covariance of `+u²` doubles the independent variance, `−u²`
/// cancels it.
#[test]
fn a_covariance_entry_adds_twice_itself_to_the_variance() {
    let u: f64 = 1e-3;
    let with = |cov: &str| {
        vmc(
            "EX0X = { value = 0.0, u = 1e-3 }",
            "",
            &format!("[spindle]\nEXS = {{ value = 0.002, u = 1e-3 }}\n{cov}"),
        )
    };
    let at = [250.0, 100.0, 50.0, 0.0, 0.0, 0.0];
    let independent = u_at(&with(""), at)[0];
    assert!(
        close(independent, (2.0 * u * u).sqrt(), 1e-9),
        "{independent}"
    );
    let positive = with("[covariance]\n\"axes.X.EX0X spindle.EXS\" = 1e-6\n");
    assert_eq!(positive.uncertainty.covariance.len(), 1);
    let got = u_at(&positive, at)[0];
    assert!(
        close(got * got, 2.0 * independent * independent, 1e-9),
        "{got}"
    );
    let negative = with("[covariance]\n\"spindle.EXS axes.X.EX0X\" = -1e-6\n");
    assert!(u_at(&negative, at)[0] < 1e-9, "{:?}", u_at(&negative, at));
}

/// A `per_kelvin` coefficient's u times ΔT; a `reverse`'s u for the negative approach alone,
/// the `value`'s for the positive.
#[test]
fn thermal_and_reverse_parts_carry_their_own_u() {
    let thermal = vmc(
        "",
        "",
        "[thermal]\nreference_C = 20.0\ninputs = [\"spindle\"]\n\
         [spindle]\nEZS = { value = 0.0, per_kelvin = { spindle = { value = -0.0015, u = 1e-4 } } }",
    );
    assert_eq!(
        thermal.uncertainty.values[0].name,
        "spindle.EZS.per_kelvin.spindle"
    );
    let at = [100.0, 100.0, 100.0, 0.0, 0.0, 0.0];
    let inputs = Inputs::parse("spindle=30", "", &thermal).unwrap();
    assert!(close(u_at(&thermal.at(&inputs), at)[2], 10.0 * 1e-4, 1e-9));
    assert!(u_at(&thermal, at)[2] < 1e-15, "at the reference ΔT = 0");

    let reverse = vmc(
        "EXX = { value = 0.0, u = 1e-3, reverse = { value = 0.002, u = 3e-3 } }",
        "",
        "",
    );
    let names: Vec<&str> = reverse
        .uncertainty
        .values
        .iter()
        .map(|v| v.name.as_str())
        .collect();
    assert_eq!(names, ["axes.X.EXX", "axes.X.EXX.reverse"]);
    let plus = Inputs::parse("", "X=+", &reverse).unwrap();
    let minus = Inputs::parse("", "X=-", &reverse).unwrap();
    assert!(close(u_at(&reverse.at(&plus), at)[0], 1e-3, 1e-9));
    assert!(close(u_at(&reverse.at(&minus), at)[0], 3e-3, 1e-9));
}

/// Each embedded machine with u added to a few values (a location error of every axis, its
/// tables' nodes and polynomials, a spindle error) and one covariance entry: the Monte Carlo
/// standard deviation of VE agrees with first order within 4 of its own standard errors, and
/// its mean with the nominal VE within 4 of the mean's.
#[test]
fn monte_carlo_agrees_with_first_order_on_every_embedded_machine() {
    assert_eq!(EMBEDDED.len(), 5);
    for (name, text) in EMBEDDED {
        let machine =
            Machine::from_toml(&with_u(text), name, None).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(machine.uncertainty.values.len() >= 4, "{name}");
        assert_eq!(machine.uncertainty.covariance.len(), 1, "{name}");
        let points = points_of(&machine);
        assert_eq!(points.len(), 4);
        let propagation = Propagation::new(&machine);
        let draws = 3000;
        let mc = propagation.monte_carlo(&points, draws, 7).unwrap();
        assert_eq!((mc.std.len(), mc.mean.len()), (4, 4));
        let twin = volmap::reference::Twin::of(&machine);
        for (p, command) in points.iter().enumerate() {
            let first = propagation.first_order(command);
            let (se, me) = (mc.std_error(p), mc.mean_error(p));
            let nominal = twin.deviation(command).volumetric_mm;
            for c in 0..3 {
                assert!(first[c] > 0.0, "{name} {command:?} VE[{c}] has no spread");
                let gap = (mc.std[p][c] - first[c]).abs();
                assert!(
                    gap <= 4.0 * se[c],
                    "{name} at {command:?}, VE[{c}]: MC {} vs first order {} (se {})",
                    mc.std[p][c],
                    first[c],
                    se[c]
                );
                let off = (mc.mean[p][c] - nominal[c]).abs();
                assert!(
                    off <= 4.0 * me[c],
                    "{name} {command:?} mean VE[{c}] off by {off}"
                );
            }
        }
    }
}

/// Four commands inside the travels, each axis at a different fraction of its own.
fn points_of(machine: &Machine) -> Vec<Command> {
    [0.2, 0.45, 0.7, 0.95]
        .iter()
        .map(|&f: &f64| {
            let mut c = [0.0; 6];
            for (n, axis) in machine.axes.iter().enumerate() {
                let [lo, hi] = axis.range;
                let g = (f + 0.3 * n as f64).fract();
                c[axis.letter.index()] = lo + (hi - lo) * g;
            }
            c
        })
        .collect()
}

/// The machine file with u on: the location errors `EX0k EY0k EZ0k EB0k` of every axis (added
/// at 0 where the file has none), every shorthand table (1 µm per node, 2 µrad for
/// an angle) and polynomial, and the spindle's EZS; and a covariance of half the product of the
/// u of the first two axes' `EX0k`.
fn with_u(text: &str) -> String {
    let mut file: toml::Table = text.parse().unwrap();
    let axes = file["axes"].as_table_mut().unwrap();
    let letters: Vec<String> = axes.keys().cloned().collect();
    for (letter, section) in axes.iter_mut() {
        let section = section.as_table_mut().unwrap();
        let locations = [("X", 1e-3), ("Y", 1e-3), ("Z", 1e-3), ("B", 2e-6)];
        for (key, u) in locations.map(|(c, u)| (format!("E{c}0{letter}"), u)) {
            let value = section.remove(&key).unwrap_or(toml::Value::Float(0.0));
            let mut general = toml::Table::new();
            if let toml::Value::Table(t) = &value {
                general = t.clone();
            } else {
                general.insert("value".into(), value);
            }
            general.insert("u".into(), toml::Value::Float(u));
            section.insert(key, toml::Value::Table(general));
        }
        for (key, value) in section.iter_mut() {
            let angular = key.len() == 3 && "ABC".contains(&key[1..2]);
            let u = if angular { 2e-6 } else { 1e-3 };
            let Some(form) = value.as_table_mut() else {
                continue;
            };
            if let Some(nodes) = form.get("table").and_then(|t| t.as_array()) {
                let per_node = vec![toml::Value::Float(u); nodes.len()];
                form.insert("u".into(), toml::Value::Array(per_node));
            } else if form.contains_key("poly") {
                form.insert("u".into(), toml::Value::Float(u));
            }
        }
    }
    let spindle = file
        .entry("spindle")
        .or_insert(toml::Value::Table(toml::Table::new()))
        .as_table_mut()
        .unwrap();
    let ezs = spindle.remove("EZS").unwrap_or(toml::Value::Float(0.0));
    if ezs.is_table() {
        spindle.insert("EZS".into(), ezs);
    } else {
        let mut general = toml::Table::new();
        general.insert("value".into(), ezs);
        general.insert("u".into(), toml::Value::Float(2e-3));
        spindle.insert("EZS".into(), toml::Value::Table(general));
    }
    let mut covariance = toml::Table::new();
    covariance.insert(
        format!(
            "axes.{a}.EX0{a} axes.{b}.EX0{b}",
            a = letters[0],
            b = letters[1]
        ),
        toml::Value::Float(0.5e-6),
    );
    file.insert("covariance".into(), toml::Value::Table(covariance));
    toml::to_string(&file).unwrap()
}
