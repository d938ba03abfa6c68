//! The page itself: the template, its style and script (assets/view/, written for volmap, no
//! library) and the data, put together into one file.

use super::ViewData;

const TEMPLATE: &str = include_str!("../../assets/view/view.html");
const STYLE: &str = include_str!("../../assets/view/view.css");
const SCRIPT: &str = include_str!("../../assets/view/view.js");

/// The placeholders of the template, each replaced once.
const STYLE_AT: &str = "/*VOLMAP_STYLE*/";
const SCRIPT_AT: &str = "/*VOLMAP_SCRIPT*/";
const DATA_AT: &str = "/*VOLMAP_DATA*/";
const TITLE_AT: &str = "VOLMAP_TITLE";

/// The HTML page of `data`: one file, every script and value inside it.
pub fn page(data: &ViewData) -> String {
    let json = serde_json::to_string(data).expect("the page's data serialize");
    // Inside a <script> element only `</` can end it early; `<\/` is the same JSON string.
    let json = json.replace("</", "<\\/");
    let title = html_text(&format!("{}: volumetric error", data.machine));
    TEMPLATE
        .replacen(TITLE_AT, &title, 1)
        .replacen(STYLE_AT, STYLE, 1)
        .replacen(DATA_AT, &json, 1)
        .replacen(SCRIPT_AT, SCRIPT, 1)
}

/// `text` with the characters HTML gives a meaning escaped.
fn html_text(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_template_has_each_placeholder_once() {
        for at in [STYLE_AT, SCRIPT_AT, DATA_AT, TITLE_AT] {
            assert_eq!(TEMPLATE.matches(at).count(), 1, "{at}");
        }
        // The script and style must not carry a placeholder of their own.
        for at in [STYLE_AT, SCRIPT_AT, DATA_AT] {
            assert!(!SCRIPT.contains(at) && !STYLE.contains(at), "{at}");
        }
    }

    #[test]
    fn data_cannot_close_its_script_element() {
        let mut data = super::super::view_data(
            ("</script><b>", "FYXFZ"),
            "x".into(),
            "cpu".into(),
            Vec::new(),
        );
        data.part_file = Some("</SCRIPT>".into());
        let html = page(&data);
        let start = html.find("id=\"volmap-data\"").unwrap();
        let end = html[start..].find("</script>").unwrap() + start;
        let json = &html[html[start..].find('>').unwrap() + start + 1..end];
        let back: serde_json::Value = serde_json::from_str(json).unwrap();
        assert_eq!(back["machine"], "</script><b>");
        assert_eq!(back["part_file"], "</SCRIPT>");
        assert!(html.contains("<title>&lt;/script&gt;&lt;b&gt;: volumetric error</title>"));
    }
}
