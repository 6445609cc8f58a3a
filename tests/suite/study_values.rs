//! A study given as values (a TOML table with no text, as a dict from Python crosses) is
//! the study its text gives, and its errors name the key as a file's do, with no line.

use chassis_mc::study::Study;

use super::common::*;

fn values(text: &str) -> toml::Table {
    text.parse().unwrap()
}

#[test]
fn a_study_given_as_values_is_the_study_its_text_gives() {
    let path = study_path("thesis.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let dir = path.parent().unwrap();
    let from_text = Study::from_toml_in(&text, "<string>", dir).unwrap();
    let from_values = Study::from_table_in(values(&text), "<dict>", dir).unwrap();
    assert_eq!(from_values.to_toml(), from_text.to_toml());
    assert_eq!(from_values.identity(), from_text.identity());
    // and back: a study's values as run give it again
    let again = Study::from_table_in(from_text.to_table(), "<dict>", dir).unwrap();
    assert_eq!(again.to_toml(), from_text.to_toml());
}

#[test]
fn errors_of_values_name_the_key_as_those_of_text_do() {
    let path = study_path("thesis.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let dir = path.parent().unwrap();
    let edits = [
        // a value out of range (validation), a mistyped value, an unknown key with a home
        // elsewhere, a missing key
        set_key(&text, "mass", "-3.0"),
        set_key(&text, "mass", "\"heavy\""),
        text.replacen("[vehicle]\n", "[vehicle]\nmin_speed = 1.0\n", 1),
        text.lines()
            .filter(|l| !l.starts_with("frontal_area"))
            .collect::<Vec<_>>()
            .join("\n"),
    ];
    for edited in edits {
        let by_text = Study::from_toml_in(&edited, "<string>", dir).unwrap_err();
        let by_values = Study::from_table_in(values(&edited), "<dict>", dir).unwrap_err();
        assert_eq!(by_values.key, by_text.key, "{by_text}");
        assert_eq!(by_values.reason, by_text.reason, "{by_text}");
        assert!(by_text.line.is_some() && by_values.line.is_none());
    }
}
