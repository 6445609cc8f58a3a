//! `fleet.filter`: which rows of a fleet's table are vehicles. Each expression is
//! `COLUMN OP VALUE`: the column's name in double quotes (or a bare name without spaces), one
//! of `==`, `!=`, `<`, `<=`, `>`, `>=`, and a value in double quotes (text, compared exactly
//! after trimming; `==` and `!=` only) or a number (the cell read as a number; a cell that
//! is not one never matches). A row is kept when every expression holds.

/// One comparison of a filter.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Filter {
    /// The column compared.
    pub column: String,
    op: Op,
    value: Value,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Op {
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
}

#[derive(Debug, Clone, PartialEq)]
enum Value {
    Text(String),
    Number(f64),
}

/// The operators, longest first (so `<=` is not read as `<`).
const OPS: [(&str, Op); 6] = [
    ("==", Op::Eq),
    ("!=", Op::Ne),
    ("<=", Op::Le),
    (">=", Op::Ge),
    ("<", Op::Lt),
    (">", Op::Gt),
];

/// A quoted name or text at the start of `s` and the rest, or a bare word.
fn token(s: &str) -> Option<(String, &str)> {
    let s = s.trim_start();
    if let Some(rest) = s.strip_prefix('"') {
        let end = rest.find('"')?;
        return Some((rest[..end].to_string(), &rest[end + 1..]));
    }
    let end = s
        .find(|c: char| c.is_whitespace() || "=!<>".contains(c))
        .unwrap_or(s.len());
    (end > 0).then(|| (s[..end].to_string(), &s[end..]))
}

impl Filter {
    /// Parse `COLUMN OP VALUE`.
    pub fn parse(text: &str) -> Result<Filter, String> {
        let form = "expected COLUMN OP VALUE, e.g. \"Test Category\" == \"FTP\" or \
                    \"Equivalent Test Weight (lbs.)\" <= 6000";
        let (column, rest) = token(text).ok_or_else(|| format!("{form}; got {text:?}"))?;
        let rest = rest.trim_start();
        let (op, rest) = OPS
            .iter()
            .find_map(|(s, op)| rest.strip_prefix(s).map(|r| (*op, r)))
            .ok_or_else(|| format!("{form}; got {text:?} (no operator after the column)"))?;
        let rest = rest.trim();
        let value = if rest.starts_with('"') {
            match token(rest) {
                Some((v, tail)) if tail.trim().is_empty() => Value::Text(v),
                _ => {
                    return Err(format!(
                        "{form}; got {text:?} (the text value is not closed)"
                    ));
                }
            }
        } else {
            let v: f64 = rest
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| {
                    format!(
                        "{form}; got {text:?} ({rest:?} is neither \"text\" nor a finite number)"
                    )
                })?;
            Value::Number(v)
        };
        if matches!(value, Value::Text(_)) && !matches!(op, Op::Eq | Op::Ne) {
            return Err(format!(
                "{text:?}: text is compared with == or != only; compare a number without quotes"
            ));
        }
        Ok(Filter { column, op, value })
    }

    /// Whether a row whose cell of the column is `cell` passes.
    pub fn keeps(&self, cell: &str) -> bool {
        let cell = cell.trim();
        match &self.value {
            Value::Text(t) => (cell == t) == (self.op == Op::Eq),
            Value::Number(v) => match cell.parse::<f64>() {
                Ok(x) => match self.op {
                    Op::Eq => x == *v,
                    Op::Ne => x != *v,
                    Op::Lt => x < *v,
                    Op::Le => x <= *v,
                    Op::Gt => x > *v,
                    Op::Ge => x >= *v,
                },
                Err(_) => false,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filters_read_quoted_columns_text_and_numbers() {
        let f = Filter::parse(r#""Test Category" == "FTP""#).unwrap();
        assert_eq!(f.column, "Test Category");
        assert!(f.keeps(" FTP") && !f.keeps("HWY"));
        let f = Filter::parse(r#""Equivalent Test Weight (lbs.)" <= 4000"#).unwrap();
        assert!(f.keeps("3875") && f.keeps("4000") && !f.keeps("4250") && !f.keeps(""));
        let f = Filter::parse("Year != 2021").unwrap();
        assert!(f.keeps("2022") && !f.keeps("2021"));
        assert!(Filter::parse(r#""A" < "x""#).is_err());
        assert!(Filter::parse(r#""A" = 3"#).is_err());
        assert!(Filter::parse(r#""A" == "x"#).is_err());
        assert!(Filter::parse(r#""A" != nan"#).is_err());
    }
}
