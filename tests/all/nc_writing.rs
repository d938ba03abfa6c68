//! What a compensated program keeps of its blocks (docs/nc.md, "Writing" and "Reading"): the note
//! volmap writes at its head after the program number, and every word of a block it rewrites.

use volmap::nc;

/// FANUC-family controls expect the program number first after `%`: the note goes after the `O`
/// line (and after `%`), and at the very head where there is neither (by hand).
#[test]
fn the_note_goes_after_the_program_number() {
    assert_eq!(
        nc::with_note("%\nO1234 (PART)\nG0 X0\n%\n", "made"),
        "%\nO1234 (PART)\n(made)\nG0 X0\n%\n"
    );
    assert_eq!(
        nc::with_note("O0001\r\nG0 X0\r\n", "made"),
        "O0001\r\n(made)\nG0 X0\r\n"
    );
    assert_eq!(
        nc::with_note(":42\nG0 X0\n", "made"),
        ":42\n(made)\nG0 X0\n"
    );
    assert_eq!(nc::with_note("%\nG0 X0\n", "made"), "%\n(made)\nG0 X0\n");
    assert_eq!(nc::with_note("G0 X0\n", "made"), "(made)\nG0 X0\n");
    // An `O` that is not a program number (a word of a block) stays below the note.
    assert_eq!(
        nc::with_note("G0 X0\nO12\n", "made"),
        "(made)\nG0 X0\nO12\n"
    );
    // A program of one number line without a line end.
    assert_eq!(nc::with_note("O12", "made"), "O12\n(made)\n");
}
