//! The reference's values for the embedded machines at fixed points, against a small golden
//! file. Regenerate with `VOLMAP_BLESS=1 cargo test golden` after a deliberate change, and say
//! why in the commit.

use std::fmt::Write;

use volmap::io::embedded;
use volmap::reference::deviation;

use super::common::Rng;

const GOLDEN: &str = "tests/golden/reference.csv";

fn current() -> String {
    let mut out = String::from("machine,X,Y,Z,A,B,C,VE.X,VE.Y,VE.Z,OE.X,OE.Y,OE.Z\n");
    for (name, _) in embedded::EMBEDDED {
        let machine = embedded::load(name).unwrap();
        let mut rng = Rng::new(11);
        for _ in 0..6 {
            let mut command = [0.0; 6];
            for axis in &machine.axes {
                let [lo, hi] = axis.range;
                command[axis.letter.index()] = (rng.uniform(lo, hi) * 1000.0).round() / 1000.0;
            }
            let d = deviation(&machine, &command);
            write!(out, "{name}").unwrap();
            for q in command {
                write!(out, ",{q}").unwrap();
            }
            for v in d.volumetric_mm.iter().chain(d.orientation_rad.iter()) {
                write!(out, ",{v:.15e}").unwrap();
            }
            out.push('\n');
        }
    }
    out
}

#[test]
fn golden_reference_values() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(GOLDEN);
    let now = current();
    if std::env::var_os("VOLMAP_BLESS").is_some() {
        std::fs::write(&path, &now).unwrap();
        return;
    }
    let stored =
        std::fs::read_to_string(&path).expect("golden file; create it with VOLMAP_BLESS=1");
    assert_eq!(stored.lines().count(), now.lines().count());
    for (n, (want, got)) in stored.lines().zip(now.lines()).enumerate() {
        let (w, g): (Vec<&str>, Vec<&str>) = (want.split(',').collect(), got.split(',').collect());
        assert_eq!(w.len(), g.len(), "line {}", n + 1);
        for (a, b) in w.iter().zip(&g) {
            match (a.parse::<f64>(), b.parse::<f64>()) {
                (Ok(x), Ok(y)) => assert!(
                    (x - y).abs() <= 1e-12 * x.abs().max(1e-9),
                    "{GOLDEN} line {}: {x} vs {y}",
                    n + 1
                ),
                _ => assert_eq!(a, b, "{GOLDEN} line {}", n + 1),
            }
        }
    }
}
