//! The little XML that VTU files use: elements, attributes, text, comments and declarations,
//! with line numbers for errors. `<AppendedData>` ends the scan, because what follows its `_` is
//! raw binary that no XML parser accepts (the reason a general XML crate does not fit here).

use std::ops::Range;
use std::path::Path;

use super::text::shorten;
use crate::error::{Error, Result};

/// An element with its attributes, its direct text and its children.
#[derive(Debug, Default)]
pub(crate) struct Element {
    pub name: String,
    pub attrs: Vec<(String, String)>,
    /// 1-based line of the start tag.
    pub line: usize,
    /// Byte range of the element's direct text (from the first to the last text chunk).
    pub text: Option<Range<usize>>,
    pub children: Vec<Element>,
}

impl Element {
    /// The value of attribute `name`.
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }

    /// The first child called `name`.
    pub fn child(&self, name: &str) -> Option<&Element> {
        self.children.iter().find(|c| c.name == name)
    }
}

/// The `<AppendedData>` element: its attributes and where its data (after `_`) starts and ends.
#[derive(Debug)]
pub(crate) struct Appended {
    pub encoding: String,
    pub data: Range<usize>,
    pub line: usize,
}

/// Parse `data` into its root element and the appended data, if any.
pub(crate) fn parse(path: &Path, data: &[u8]) -> Result<(Element, Option<Appended>)> {
    let mut stack: Vec<Element> = vec![Element::default()];
    let mut pos = 0;
    let mut line = 1;
    let err = |line: usize, m: String| Error::parse(path, Some(line), m);
    let find = |from: usize, pat: &[u8]| -> Option<usize> {
        data.get(from..)?
            .windows(pat.len())
            .position(|w| w == pat)
            .map(|p| from + p)
    };
    let newlines = |r: Range<usize>| data[r].iter().filter(|&&b| b == b'\n').count();
    let mut appended = None;
    while pos < data.len() {
        let lt = data[pos..]
            .iter()
            .position(|&b| b == b'<')
            .map_or(data.len(), |p| pos + p);
        if lt > pos && data[pos..lt].iter().any(|b| !b.is_ascii_whitespace()) {
            let top = stack.last_mut().expect("the document node is never popped");
            top.text = Some(match &top.text {
                Some(r) => r.start..lt,
                None => pos..lt,
            });
        }
        line += newlines(pos..lt);
        pos = lt;
        if pos >= data.len() {
            break;
        }
        let rest = &data[pos..];
        let skip_to = |pat: &[u8], what: &str| {
            find(pos, pat)
                .map(|e| e + pat.len())
                .ok_or_else(|| err(line, format!("unterminated {what}")))
        };
        if rest.starts_with(b"<?") {
            let end = skip_to(b"?>", "declaration")?;
            line += newlines(pos..end);
            pos = end;
        } else if rest.starts_with(b"<!--") {
            let end = skip_to(b"-->", "comment")?;
            line += newlines(pos..end);
            pos = end;
        } else if rest.starts_with(b"<!") {
            let end = skip_to(b">", "declaration")?;
            line += newlines(pos..end);
            pos = end;
        } else if rest.starts_with(b"</") {
            let end = skip_to(b">", "end tag")?;
            let name = String::from_utf8_lossy(&data[pos + 2..end - 1])
                .trim()
                .to_string();
            let element = stack.pop().filter(|_| !stack.is_empty());
            match element {
                Some(e) if e.name == name => {
                    stack
                        .last_mut()
                        .expect("checked non-empty")
                        .children
                        .push(e);
                }
                Some(e) => {
                    return Err(err(
                        line,
                        format!(
                            "`</{}>` closes `<{}>` (opened on line {})",
                            shorten(&name),
                            shorten(&e.name),
                            e.line
                        ),
                    ));
                }
                None => return Err(err(line, format!("unexpected `</{}>`", shorten(&name)))),
            }
            line += newlines(pos..end);
            pos = end;
        } else {
            let end = skip_to(b">", "start tag")?;
            let self_closing = data[end - 2] == b'/' && end - 2 > pos;
            let inner = &data[pos + 1..if self_closing { end - 2 } else { end - 1 }];
            let element = start_tag(inner, line).map_err(|m| err(line, m))?;
            let tag_line = line;
            line += newlines(pos..end);
            pos = end;
            if element.name == "AppendedData" {
                let underscore = find(pos, b"_")
                    .ok_or_else(|| err(tag_line, "<AppendedData> has no `_` marker".into()))?;
                let close = data
                    .windows(b"</AppendedData>".len())
                    .rposition(|w| w == b"</AppendedData>")
                    .filter(|&c| c > underscore)
                    .unwrap_or(data.len());
                appended = Some(Appended {
                    encoding: element.attr("encoding").unwrap_or("raw").to_string(),
                    data: underscore + 1..close,
                    line: tag_line,
                });
                break;
            }
            if self_closing {
                stack
                    .last_mut()
                    .expect("the document node is never popped")
                    .children
                    .push(element);
            } else {
                stack.push(element);
            }
        }
    }
    // After appended data, the open elements are closed by the part of the file not scanned.
    while stack.len() > 1 {
        let e = stack.pop().expect("len > 1");
        if appended.is_none() {
            return Err(err(
                line,
                format!(
                    "unexpected end of file: `<{}>` (line {}) is not closed",
                    shorten(&e.name),
                    e.line
                ),
            ));
        }
        stack.last_mut().expect("len ≥ 1").children.push(e);
    }
    let mut document = stack.pop().expect("the document node");
    if document.children.len() != 1 {
        return Err(err(1, "not an XML document with one root element".into()));
    }
    Ok((document.children.remove(0), appended))
}

/// `name attr="value" …` of a start tag.
fn start_tag(inner: &[u8], line: usize) -> std::result::Result<Element, String> {
    let text = std::str::from_utf8(inner).map_err(|_| "a tag is not valid UTF-8".to_string())?;
    let text = text.trim();
    let name_end = text
        .find(|c: char| c.is_ascii_whitespace())
        .unwrap_or(text.len());
    let name = &text[..name_end];
    if name.is_empty() {
        return Err("empty tag name".into());
    }
    let mut attrs = Vec::new();
    let mut rest = text[name_end..].trim_start();
    while !rest.is_empty() {
        let eq = rest
            .find('=')
            .ok_or_else(|| format!("attribute without a value in <{}>", shorten(name)))?;
        let key = rest[..eq].trim().to_string();
        let after = rest[eq + 1..].trim_start();
        let quote = after
            .chars()
            .next()
            .filter(|&q| q == '"' || q == '\'')
            .ok_or_else(|| format!("attribute `{}` is not quoted", shorten(&key)))?;
        let close = after[1..]
            .find(quote)
            .ok_or_else(|| format!("attribute `{}` is not closed", shorten(&key)))?;
        attrs.push((key, unescape(&after[1..1 + close])));
        rest = after[close + 2..].trim_start();
    }
    Ok(Element {
        name: name.to_string(),
        attrs,
        line,
        ..Default::default()
    })
}

fn unescape(s: &str) -> String {
    s.replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&amp;", "&")
}

/// Escape text for an attribute value.
pub(crate) fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('"', "&quot;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tree_text_and_appended_data() {
        let doc = b"<?xml version=\"1.0\"?>\n<!-- c -->\n<A x='1' y=\"a&amp;b\">\n <B/>\n <C>12 3</C>\n<AppendedData encoding=\"raw\">\n _\x00\x01<\n</AppendedData></A>";
        let (root, appended) = parse(Path::new("t.vtu"), doc).unwrap();
        assert_eq!(root.name, "A");
        assert_eq!(root.attr("y"), Some("a&b"));
        assert_eq!(root.children.len(), 2);
        let c = root.child("C").unwrap();
        assert_eq!(&doc[c.text.clone().unwrap()], b"12 3");
        assert_eq!(c.line, 5);
        let a = appended.unwrap();
        assert_eq!(&doc[a.data], b"\x00\x01<\n");
    }

    #[test]
    fn mismatched_and_unclosed_tags_name_their_lines() {
        let e = parse(Path::new("t"), b"<A>\n<B>\n</A>")
            .unwrap_err()
            .to_string();
        assert_eq!(e, "t:3: `</A>` closes `<B>` (opened on line 2)");
        let e = parse(Path::new("t"), b"<A>\n<B/>").unwrap_err().to_string();
        assert!(e.contains("`<A>` (line 1) is not closed"), "{e}");
    }
}
