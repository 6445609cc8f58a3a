//! Where each key of a study file sits, so that every error can name its line.
//!
//! serde tells us *what* is wrong and gives a byte span; this index turns spans and dotted
//! key paths (`vehicle.mass`, `terrain.scales[3]`) into 1-based line numbers.

use std::collections::BTreeMap;
use std::ops::Range;

use toml::de::{DeTable, DeValue};

/// Dotted key paths of a TOML document with the byte spans of their keys and values.
#[derive(Debug, Clone, Default)]
pub struct KeySpans {
    /// path → (span of the key, span of the value)
    entries: BTreeMap<String, (Range<usize>, Range<usize>)>,
    /// byte offsets at which each line starts
    line_starts: Vec<usize>,
}

impl KeySpans {
    /// Index `text`; returns an empty index (lines only) when the text does not parse.
    pub fn new(text: &str) -> Self {
        let mut line_starts = vec![0];
        line_starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        let mut spans = KeySpans {
            entries: BTreeMap::new(),
            line_starts,
        };
        if let Ok(table) = DeTable::parse(text) {
            spans.walk_table("", table.get_ref());
        }
        spans
    }

    fn walk_table(&mut self, prefix: &str, table: &DeTable<'_>) {
        for (key, value) in table.iter() {
            let path = join(prefix, key.get_ref());
            self.walk_value(path, key.span(), value.span(), value.get_ref());
        }
    }

    fn walk_value(
        &mut self,
        path: String,
        key_span: Range<usize>,
        value_span: Range<usize>,
        value: &DeValue<'_>,
    ) {
        match value {
            DeValue::Table(inner) => self.walk_table(&path, inner),
            DeValue::Array(items) => {
                for (i, item) in items.iter().enumerate() {
                    let item_path = format!("{path}[{i}]");
                    self.walk_value(item_path, item.span(), item.span(), item.get_ref());
                }
            }
            _ => {}
        }
        self.entries.insert(path, (key_span, value_span));
    }

    /// 1-based line of a byte offset.
    pub fn line_of(&self, offset: usize) -> usize {
        match self.line_starts.binary_search(&offset) {
            Ok(i) => i + 1,
            Err(i) => i,
        }
    }

    /// Line of the key `path` (for array items, of the item), if the document has it.
    pub fn line(&self, path: &str) -> Option<usize> {
        self.entries
            .get(path)
            .map(|(key, _)| self.line_of(key.start))
    }

    /// The innermost key whose key or value span contains `span`, with its line.
    pub fn key_at(&self, span: &Range<usize>) -> Option<(String, usize)> {
        self.entries
            .iter()
            .filter(|(_, (key, value))| contains(key, span) || contains(value, span))
            // the innermost is the one with the smallest enclosing value span
            .min_by_key(|(_, (key, value))| {
                if contains(key, span) {
                    key.len()
                } else {
                    value.len()
                }
            })
            .map(|(path, (key, _))| (path.clone(), self.line_of(key.start)))
    }
}

fn join(prefix: &str, key: &str) -> String {
    if prefix.is_empty() {
        key.to_string()
    } else {
        format!("{prefix}.{key}")
    }
}

fn contains(outer: &Range<usize>, inner: &Range<usize>) -> bool {
    outer.start <= inner.start && inner.end <= outer.end && !outer.is_empty()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nested_keys_and_arrays_have_lines() {
        let text = "name = \"x\"\n[terrain]\nheight = 25.0\nscales = [1.0,\n 2.0]\n";
        let spans = KeySpans::new(text);
        assert_eq!(spans.line("name"), Some(1));
        assert_eq!(spans.line("terrain"), Some(2));
        assert_eq!(spans.line("terrain.height"), Some(3));
        assert_eq!(spans.line("terrain.scales"), Some(4));
        assert_eq!(spans.line("terrain.scales[1]"), Some(5));
        let offset = text.find("2.0").unwrap();
        let (key, line) = spans.key_at(&(offset..offset + 3)).unwrap();
        assert_eq!((key.as_str(), line), ("terrain.scales[1]", 5));
    }
}
