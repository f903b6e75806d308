//! The library's messages in the words of a front end whose options are keywords (the
//! Python package's arguments, the service's query parameters): a message advises the
//! command line's flags (`--cell 0.375`, `or --aesthetic`), which those front ends name
//! as options (`cell=0.375`, `aesthetic=true`).

/// Options that are switches: `--aesthetic` is `aesthetic` set true.
const SWITCHES: &[&str] = &[
    "aesthetic",
    "fill",
    "fit_radius",
    "require_flat",
    "suitability",
    "wall_thickness",
];

/// Options that take a value: `--cell 0.375` is `cell=0.375`, `(--max-nodes)` is
/// `(max_nodes)`. `units` is the part's, not the study's, but a keyword of both front ends.
const VALUES: &[&str] = &[
    "cell",
    "centre",
    "circle_points",
    "color_by",
    "cosmetic",
    "demold",
    "flat_tol",
    "gamma_opt",
    "gate_at",
    "gate_radius",
    "gates",
    "grid_offset",
    "k",
    "keep_out",
    "material",
    "max_nodes",
    "mu_opt",
    "n",
    "nearest",
    "objective",
    "parting_line",
    "spacing",
    "strategy",
    "t_melt",
    "t_wall",
    "thickness_rule",
    "units",
];

/// The words an option takes as its value (`--objective length`); none for an option
/// whose value is a number or a name, so that the word after such a flag stays the
/// sentence's (`a coarser --cell takes less time`).
fn words_of(key: &str) -> &'static [&'static str] {
    match key {
        "centre" => &["surface", "volume"],
        "nearest" => &["3d", "2d"],
        "parting_line" => &["outline", "longest", "longest-loop"],
        "thickness_rule" => &["require", "ignore"],
        "strategy" => &["paper", "balanced"],
        "objective" => &["length", "resistance"],
        "color_by" => &["flow-length", "fill-order", "fill-time", "wall", "height"],
        "units" => &["mm", "cm", "m", "in"],
        "demold" => &["auto"],
        _ => &[],
    }
}

/// `message` with every command-line flag of a study option named as its keyword: a switch
/// as `key=truth` (`"true"` for the service's query, `"True"` for Python), a flag with a
/// value after it as `key=value`, any other as `key`. Flags of no option (`--json`) stay.
pub fn keyword_words(message: &str, truth: &str) -> String {
    let mut out = String::with_capacity(message.len() + 16);
    let mut rest = message;
    while let Some(at) = rest.find("--") {
        out.push_str(&rest[..at]);
        let after = &rest[at + 2..];
        let len = after
            .find(|c: char| !(c.is_ascii_lowercase() || c == '-'))
            .unwrap_or(after.len());
        let flag = after[..len].trim_end_matches('-');
        let key = flag.replace('-', "_");
        let tail = &after[flag.len()..];
        if SWITCHES.contains(&key.as_str()) {
            out.push_str(&key);
            out.push('=');
            out.push_str(truth);
            rest = tail;
        } else if VALUES.contains(&key.as_str()) {
            out.push_str(&key);
            rest = tail;
            // A value right after the flag: a number, a word (`length`, `in`, `2d`), or a
            // placeholder of one capital (`--gates K`); a page's markup ends it too.
            if let Some(value) = tail.strip_prefix(' ') {
                let end = value
                    .find(|c: char| c.is_whitespace() || matches!(c, ',' | ';' | ':' | ')' | '<'))
                    .unwrap_or(value.len());
                // A sentence's full stop after a word is not the word's.
                let end = match value[..end].parse::<f64>() {
                    Ok(_) => end,
                    Err(_) => value[..end].trim_end_matches('.').len(),
                };
                let word = &value[..end];
                let is_value = word.parse::<f64>().is_ok()
                    || (word.len() == 1 && word.chars().all(|c| c.is_ascii_uppercase()))
                    || words_of(&key).contains(&word);
                if is_value {
                    out.push('=');
                    out.push_str(word);
                    rest = &value[end..];
                }
            }
        } else {
            out.push_str("--");
            rest = after;
        }
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_become_keywords_and_values_stay_with_them() {
        for (cli, keywords) in [
            (
                "try another demolding direction, or --aesthetic",
                "try another demolding direction, or aesthetic=true",
            ),
            (
                "use a spacing of at least 0.049 mm, or raise the node limit (--max-nodes)",
                "use a spacing of at least 0.049 mm, or raise the node limit (max_nodes)",
            ),
            (
                "flow lengths are rough; try --cell 0.375",
                "flow lengths are rough; try cell=0.375",
            ),
            (
                "--objective length minimises the longest flow path instead",
                "objective=length minimises the longest flow path instead",
            ),
            (
                "a slope; --require-flat keeps only flat nodes)",
                "a slope; require_flat=true keeps only flat nodes)",
            ),
            (
                "--demold auto: no direction without undercuts; chose (0.0000, 0.0000, 1.0000)",
                "demold=auto: no direction without undercuts; chose (0.0000, 0.0000, 1.0000)",
            ),
            (
                "set its units to in, cm or m (--units)",
                "set its units to in, cm or m (units)",
            ),
            (
                "print it with --json; -- alone",
                "print it with --json; -- alone",
            ),
            ("no flag at all", "no flag at all"),
            // The report page's glossary: values inside markup, words with digits,
            // placeholders, a full stop.
            (
                "<code>--centre volume</code> or <code>--nearest 2d</code>",
                "<code>centre=volume</code> or <code>nearest=2d</code>",
            ),
            (
                "(<code>--objective resistance</code>); with <code>--gates K</code>, K gates",
                "(<code>objective=resistance</code>); with <code>gates=K</code>, K gates",
            ),
            (
                "the centre of the volume with --centre volume.",
                "the centre of the volume with centre=volume.",
            ),
            (
                "with --parting-line longest-loop",
                "with parting_line=longest-loop",
            ),
            // A word after a flag that takes a number is the sentence's.
            (
                "in the fill stage (a coarser --cell takes less time)",
                "in the fill stage (a coarser cell takes less time)",
            ),
            (
                "(a coarser --cell or fewer --gates take less time)",
                "(a coarser cell or fewer gates take less time)",
            ),
            ("set --units in", "set units=in"),
            ("with --color-by wall changes", "with color_by=wall changes"),
        ] {
            assert_eq!(keyword_words(cli, "true"), keywords);
        }
        assert_eq!(keyword_words("or --fill", "True"), "or fill=True");
    }

    #[test]
    fn every_keyword_is_an_option_of_the_study() {
        // Each key is accepted by the study's options (`units` is the part's).
        for key in SWITCHES.iter().chain(VALUES).filter(|&&k| k != "units") {
            let json = format!("{{\"{key}\": null}}");
            let e = serde_json::from_str::<super::super::StudyOptions>(&json)
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default();
            assert!(!e.contains("unknown field"), "{key}: {e}");
        }
    }
}
