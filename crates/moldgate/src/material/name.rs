//! Material names as a designer types them: case and separators do not matter, and an
//! unknown name is answered with the closest known ones.

/// The name reduced to its letters and digits, upper-cased: `pa66-gf30`, `PA66 GF30` and
/// `pa66gf30` all give `PA66GF30`.
pub fn normalized(name: &str) -> String {
    name.chars()
        .filter(|c| c.is_alphanumeric())
        .flat_map(char::to_uppercase)
        .collect()
}

/// Whether two names are the same material name once case and separators are ignored.
pub fn same(a: &str, b: &str) -> bool {
    normalized(a) == normalized(b)
}

/// The Levenshtein distance between two strings, in characters: the fewest insertions,
/// deletions and substitutions that turn one into the other.
pub fn edit_distance(a: &str, b: &str) -> usize {
    distances_to_prefixes(a, b).last().copied().unwrap_or(0)
}

/// The edit distance from `query` to the closest prefix of `name`: `PA77` is 2 from `PA66`
/// and also 2 from `PA66-GF30` (through its prefix `PA66`), so a grade is suggested beside
/// its base resin.
fn prefix_distance(query: &str, name: &str) -> usize {
    distances_to_prefixes(query, name)
        .into_iter()
        .min()
        .unwrap_or(0)
}

/// Row `j` of the result is the edit distance from all of `a` to the first `j` characters
/// of `b` (the last row of the usual dynamic programme, one row of memory).
fn distances_to_prefixes(a: &str, b: &str) -> Vec<usize> {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let substitute = diagonal + usize::from(ca != cb);
            diagonal = row[j + 1];
            row[j + 1] = substitute.min(row[j] + 1).min(diagonal + 1);
        }
    }
    row
}

/// Up to `count` of `names` closest to `query`, closest first, comparing normalised names:
/// ranked by the distance to the closest prefix of a name (none for a name that holds the
/// query whole), then by the whole-name distance, then alphabetically. Each name appears
/// once.
pub fn closest<'a>(
    query: &str,
    names: impl IntoIterator<Item = &'a str>,
    count: usize,
) -> Vec<&'a str> {
    closest_of(query, names.into_iter().map(|n| (n, n)), count)
}

/// Like [`closest`] over `(spelling, name)` pairs: each spelling (a name or an alias) is
/// ranked, and its name is answered, once, at the rank of its closest spelling.
pub fn closest_of<'a>(
    query: &str,
    spellings: impl IntoIterator<Item = (&'a str, &'a str)>,
    count: usize,
) -> Vec<&'a str> {
    let query = normalized(query);
    let mut ranked: Vec<(usize, usize, &str)> = spellings
        .into_iter()
        .map(|(spelling, name)| {
            let key = normalized(spelling);
            // A spelling that holds the query whole ("polyethylene" in "high-density
            // polyethylene") is as close as one that starts with it.
            let near = match key.contains(query.as_str()) {
                true => 0,
                false => prefix_distance(&query, &key),
            };
            (near, edit_distance(&query, &key), name)
        })
        .collect();
    ranked.sort();
    let mut out: Vec<&str> = Vec::new();
    for (_, _, name) in ranked {
        if out.len() == count {
            break;
        }
        if !out.contains(&name) {
            out.push(name);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn separators_and_case_are_ignored() {
        for spelling in [
            "pa66-gf30",
            "PA66 GF30",
            "pa66gf30",
            "PA66_GF30",
            " Pa66/gf30 ",
        ] {
            assert_eq!(normalized(spelling), "PA66GF30", "{spelling}");
        }
        assert!(same("PC/ABS", "pc-abs"));
        assert!(!same("PA6", "PA66"));
    }

    #[test]
    fn edit_distance_closed_forms() {
        assert_eq!(edit_distance("", ""), 0);
        assert_eq!(edit_distance("ABC", ""), 3);
        assert_eq!(edit_distance("", "ABC"), 3);
        assert_eq!(edit_distance("KITTEN", "SITTING"), 3);
        assert_eq!(edit_distance("FLAW", "LAWN"), 2);
        assert_eq!(edit_distance("PA77", "PA66"), 2);
        // Symmetric, and zero only for equal strings.
        for (a, b) in [("PEEK", "PET"), ("POM", "PMMA"), ("HIPS", "PS")] {
            assert_eq!(edit_distance(a, b), edit_distance(b, a));
            assert!(edit_distance(a, b) > 0);
        }
        assert_eq!(prefix_distance("PA77", "PA66GF30"), 2);
        assert_eq!(prefix_distance("PA", "PA66GF30"), 0);
    }

    #[test]
    fn closest_names_of_an_unknown_grade() {
        let names = [
            "PP",
            "ABS",
            "PC",
            "PA6",
            "PA66",
            "PA66-GF30",
            "PET",
            "PEEK",
            "POM",
        ];
        assert_eq!(closest("PA77", names, 3), ["PA6", "PA66", "PA66-GF30"]);
        assert_eq!(closest("peak", names, 1), ["PEEK"]);
        assert_eq!(closest("abs", names, 1), ["ABS"]);
        assert_eq!(closest("x", names, 0), Vec::<&str>::new());
        assert_eq!(closest("x", ["A", "A"], 5), ["A"]);
        // An alias ranks its material but is not itself answered.
        let spellings = [("HDPE", "PE-HD"), ("PE-HD", "PE-HD"), ("PEEK", "PEEK")];
        assert_eq!(closest_of("HDP", spellings, 2), ["PE-HD", "PEEK"]);
    }
}
