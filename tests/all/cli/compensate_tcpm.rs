//! `volmap compensate` on a program written for tool-centre-point control (G43.4): compensated
//! with exit 0, the TCPM codes kept; what volmap does not follow under it refused with exit 2.

use predicates::prelude::*;

use super::volmap;

const PROGRAM: &str = "%\nO1000 (TCPM)\nG90 G21 G17 G54\nG0 B30. C45.\nG43.4 H1\nG0 X0. Y0. Z50.\nG1 Z10. F500.\nX20. Y10. B35. C30.\nX30. Y-10. Z5. B20. C60.\nG0 Z50.\nG49\nM30\n%\n";

#[test]
fn a_g43_4_program_is_compensated_and_a_g28_under_it_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (program, out) = (dir.path().join("p.nc"), dir.path().join("out.nc"));
    let run = |text: &str| {
        std::fs::write(&program, text).unwrap();
        let mut command = volmap();
        command
            .args(["compensate", "--machine", "5axis-hwang2014", "--program"])
            .arg(&program)
            .args(["--work-offset", "G54=100,400,200", "--orientation", "--out"])
            .arg(&out);
        command.assert()
    };
    run(PROGRAM).success().stdout(predicate::str::contains(
        "µrad after (angular tolerance 10.000 µrad)",
    ));
    // The codes stay; the tip's words and the rotary words are rewritten (the machine's errors
    // move the tip by tens of µm: the programmed X30. Y-10. is no longer written).
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.contains("\nG43.4 H1\n") && text.contains("\nG49\n"),
        "{text}"
    );
    let last_feed = text
        .lines()
        .rev()
        .find(|l| l.contains('Y') && !l.starts_with("G0"))
        .unwrap();
    assert!(
        !last_feed.contains("X30. ")
            && !last_feed.contains("C60. ")
            && last_feed.contains(" C60.0"),
        "{last_feed}"
    );
    // A G28 under G43.4: exit 2, naming the file, the line and what to do.
    run(&PROGRAM.replace("G0 Z50.\n", "G0 Z50.\nG28 Z0.\n"))
        .code(2)
        .stderr(
            predicate::str::contains("p.nc: line 11: G28, a move to a machine position, under")
                .and(predicate::str::contains("cancel it (G49) first")),
        );
}
