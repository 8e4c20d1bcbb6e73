//! The panel's message catalogue: the operator's words in the panel's language.
//!
//! Every text the operator reads is written once, in English, where it is made (the loop's
//! vocabulary in `hob_ipc::codec`, the set-up checks, the page's labels); a translation is
//! a gettext PO file in `frontends/hmi/lang/` (`de.po`: German), whose `msgid` is that
//! English text and `msgstr` its translation, so a translator works with the usual tools
//! (Poedit, `msgfmt --check`). A `msgid` may hold placeholders `{0}`..`{9}` for the parts
//! that vary (an axis, a value, a nested message): `soft limit {0}: {1} {2}` translates
//! `soft limit X: 12.500 mm`, and each part is itself looked up (a homing failure's words
//! inside "referencing X failed: ..."). A text the catalogue lacks is shown in English.
//!
//! The server translates what it sends (alarms, refusals, events, states, the node and
//! drive states) in the panel's language ([`set`], `hob-hmi --language`, the page's
//! language key); the page translates its own labels with the same catalogue
//! ([`Words::page`], `GET /api/words`). `tests/catalogue.rs` checks that every text the
//! vocabulary can produce has its German.

use serde::Serialize;
use std::collections::BTreeMap;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicU8, Ordering};

/// A language of the panel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
#[repr(u8)]
pub enum Lang {
    /// English: the words as written.
    En = 0,
    /// German (`lang/de.po`).
    De = 1,
}

impl Lang {
    /// Every language, in code order (`ALL[l as usize] == l`).
    pub const ALL: [Lang; 2] = [Lang::En, Lang::De];

    /// The ISO 639-1 code (`en`, `de`).
    pub const fn code(self) -> &'static str {
        match self {
            Lang::En => "en",
            Lang::De => "de",
        }
    }

    /// The language's own name, as its key on the panel shows it.
    pub const fn own_name(self) -> &'static str {
        match self {
            Lang::En => "English",
            Lang::De => "Deutsch",
        }
    }

    pub fn parse(code: &str) -> Option<Lang> {
        Self::ALL.into_iter().find(|l| l.code() == code)
    }
}

/// One translated text with placeholders: the `msgid` split at them.
#[derive(Debug, Clone)]
struct Template {
    /// The literal pieces around the placeholders (one more than `slots`).
    pieces: Vec<String>,
    /// The placeholder number of each gap, in the order of the `msgid`.
    slots: Vec<usize>,
    msgid: String,
    msgstr: String,
}

/// A problem in a PO file: its line and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PoError {
    pub line: usize,
    pub what: String,
}

impl std::fmt::Display for PoError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "line {}: {}", self.line, self.what)
    }
}

/// A language's catalogue: exact texts and texts with placeholders.
#[derive(Debug, Clone, Default)]
pub struct Catalogue {
    exact: BTreeMap<String, String>,
    templates: Vec<Template>,
}

/// The entries of a PO file (`msgid` to `msgstr`; the header and untranslated entries left
/// out). Refuses what it does not read: a `msgctxt` or plural, a string it cannot unquote, a
/// `msgid` given twice, placeholders that differ between `msgid` and `msgstr`.
pub fn parse_po(text: &str) -> Result<Vec<(String, String)>, PoError> {
    #[derive(PartialEq)]
    enum In {
        Nothing,
        Id,
        Str,
    }
    let mut out: Vec<(String, String)> = Vec::new();
    let (mut id, mut st, mut at) = (String::new(), String::new(), In::Nothing);
    let mut id_line = 0;
    let finish = |id: &mut String, st: &mut String, line: usize, out: &mut Vec<(String, String)>| {
        let (i, s) = (std::mem::take(id), std::mem::take(st));
        if i.is_empty() || s.is_empty() {
            return Ok(());
        }
        if out.iter().any(|(k, _)| *k == i) {
            return Err(PoError {
                line,
                what: format!("msgid {i:?} given twice"),
            });
        }
        if placeholders(&i) != placeholders(&s) {
            return Err(PoError {
                line,
                what: format!("msgstr of {i:?} has other placeholders than its msgid"),
            });
        }
        out.push((i, s));
        Ok(())
    };
    for (n, raw) in text.lines().enumerate() {
        let line = raw.trim();
        let n = n + 1;
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let (target, rest) = if let Some(r) = line.strip_prefix("msgid ") {
            if at == In::Str {
                finish(&mut id, &mut st, id_line, &mut out)?;
            }
            at = In::Id;
            id_line = n;
            (&mut id, r)
        } else if let Some(r) = line.strip_prefix("msgstr ") {
            if at != In::Id {
                return Err(PoError {
                    line: n,
                    what: "msgstr without its msgid".into(),
                });
            }
            at = In::Str;
            (&mut st, r)
        } else if line.starts_with('"') {
            match at {
                In::Id => (&mut id, line),
                In::Str => (&mut st, line),
                In::Nothing => {
                    return Err(PoError {
                        line: n,
                        what: "a string outside an entry".into(),
                    });
                }
            }
        } else {
            return Err(PoError {
                line: n,
                what: format!("not read here: {line:?} (msgctxt and plurals are not used)"),
            });
        };
        target.push_str(&unquote(rest).ok_or_else(|| PoError {
            line: n,
            what: format!("not a quoted string: {rest}"),
        })?);
    }
    if at == In::Str {
        finish(&mut id, &mut st, id_line, &mut out)?;
    }
    Ok(out)
}

fn unquote(s: &str) -> Option<String> {
    let inner = s.strip_prefix('"')?.strip_suffix('"')?;
    let mut out = String::with_capacity(inner.len());
    let mut chars = inner.chars();
    while let Some(c) = chars.next() {
        match c {
            '\\' => out.push(match chars.next()? {
                'n' => '\n',
                't' => '\t',
                '"' => '"',
                '\\' => '\\',
                _ => return None,
            }),
            '"' => return None,
            c => out.push(c),
        }
    }
    Some(out)
}

/// The placeholder numbers of a text, sorted.
fn placeholders(s: &str) -> Vec<usize> {
    let mut v: Vec<usize> = split_template(s).1;
    v.sort_unstable();
    v
}

/// A text split at its placeholders `{0}`..`{9}`: the pieces and the numbers between.
fn split_template(s: &str) -> (Vec<String>, Vec<usize>) {
    let (mut pieces, mut slots, mut cur) = (Vec::new(), Vec::new(), String::new());
    let b = s.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'{' && i + 2 < b.len() && b[i + 1].is_ascii_digit() && b[i + 2] == b'}' {
            pieces.push(std::mem::take(&mut cur));
            slots.push(usize::from(b[i + 1] - b'0'));
            i += 3;
        } else {
            let ch = s[i..].chars().next().unwrap_or(' ');
            cur.push(ch);
            i += ch.len_utf8();
        }
    }
    pieces.push(cur);
    (pieces, slots)
}

impl Catalogue {
    /// The catalogue of a PO file's text.
    pub fn from_po(text: &str) -> Result<Self, PoError> {
        let mut c = Catalogue::default();
        for (id, st) in parse_po(text)? {
            let (pieces, slots) = split_template(&id);
            if slots.is_empty() {
                c.exact.insert(id, st);
            } else {
                c.templates.push(Template {
                    pieces,
                    slots,
                    msgid: id,
                    msgstr: st,
                });
            }
        }
        Ok(c)
    }

    /// The translation of `s`, or `None` if the catalogue has none.
    pub fn get(&self, s: &str) -> Option<String> {
        if let Some(t) = self.exact.get(s) {
            return Some(t.clone());
        }
        self.templates.iter().find_map(|t| {
            let parts = t.capture(s)?;
            let mut out = t.msgstr.clone();
            for (slot, part) in t.slots.iter().zip(parts) {
                let part = self.get(part).unwrap_or_else(|| part.to_string());
                out = out.replace(&format!("{{{slot}}}"), &part);
            }
            Some(out)
        })
    }

    /// The translation of `s`, else `s` itself.
    pub fn tr(&self, s: &str) -> String {
        self.get(s).unwrap_or_else(|| s.to_string())
    }

    /// What the page looks its own labels up in: every entry, a `msgid` with placeholders
    /// as written (the page fills them in itself).
    pub fn page(&self) -> BTreeMap<&str, &str> {
        let exact = self.exact.iter().map(|(k, v)| (k.as_str(), v.as_str()));
        let templates = self
            .templates
            .iter()
            .map(|t| (t.msgid.as_str(), t.msgstr.as_str()));
        exact.chain(templates).collect()
    }
}

impl Template {
    /// The parts of `s` in this template's gaps, if `s` is this template filled in. A gap
    /// is never empty and ends at the first place the next piece fits (the last gap at the
    /// end of `s`).
    fn capture<'s>(&self, s: &'s str) -> Option<Vec<&'s str>> {
        let mut rest = s.strip_prefix(self.pieces[0].as_str())?;
        let mut parts = Vec::with_capacity(self.slots.len());
        for (i, next) in self.pieces[1..].iter().enumerate() {
            let last = i + 1 == self.slots.len();
            let end = if last {
                if !rest.ends_with(next.as_str()) || rest.len() <= next.len() {
                    return None;
                }
                rest.len() - next.len()
            } else {
                if next.is_empty() {
                    return None; // two placeholders side by side: no way to tell them apart
                }
                // At least one character in the gap.
                let first = rest.char_indices().nth(1).map_or(rest.len(), |(k, _)| k);
                first + rest.get(first..)?.find(next.as_str())?
            };
            parts.push(&rest[..end]);
            rest = &rest[end + next.len()..];
        }
        Some(parts)
    }
}

/// The catalogues this build has and the panel's language.
#[derive(Debug)]
pub struct Words {
    de: Catalogue,
    lang: AtomicU8,
}

/// The German catalogue as built in.
pub const DE_PO: &str = include_str!("../lang/de.po");

static WORDS: OnceLock<Words> = OnceLock::new();

fn words() -> &'static Words {
    WORDS.get_or_init(|| Words {
        // Checked by the tests (`german_catalogue_reads`): a broken file is a failed build
        // check, and the panel then speaks English rather than not starting.
        de: Catalogue::from_po(DE_PO).unwrap_or_default(),
        lang: AtomicU8::new(0),
    })
}

/// The panel's language.
pub fn lang() -> Lang {
    let i = usize::from(words().lang.load(Ordering::Relaxed));
    Lang::ALL.get(i).copied().unwrap_or(Lang::En)
}

/// Sets the panel's language (every panel and view of this server).
pub fn set(l: Lang) {
    words().lang.store(l as u8, Ordering::Relaxed);
}

/// The catalogue of a language (`None`: English, the words as written).
pub fn catalogue(l: Lang) -> Option<&'static Catalogue> {
    match l {
        Lang::En => None,
        Lang::De => Some(&words().de),
    }
}

/// `s` in the panel's language.
pub fn tr(s: &str) -> String {
    catalogue(lang()).map_or_else(|| s.to_string(), |c| c.tr(s))
}

#[cfg(test)]
mod tests {
    use super::*;

    const PO: &str = r#"
# a comment
msgid ""
msgstr "Content-Type: text/plain; charset=UTF-8\n"

msgid "idle"
msgstr "bereit"

msgid "soft limit {0}: {1} {2}"
msgstr "Software-Endlage {0}: {1} {2}"

msgid "referencing {0} failed: {1}"
msgstr "Referenzieren {0} fehlgeschlagen: {1}"

msgid "the drive did not start homing"
msgstr "der Antrieb hat die Referenzfahrt "
"nicht begonnen"

msgid "not translated yet"
msgstr ""
"#;

    #[test]
    fn exact_texts_and_continued_strings() {
        let c = Catalogue::from_po(PO).unwrap();
        assert_eq!(c.tr("idle"), "bereit");
        assert_eq!(
            c.tr("the drive did not start homing"),
            "der Antrieb hat die Referenzfahrt nicht begonnen"
        );
        assert_eq!(c.tr("not translated yet"), "not translated yet");
        assert_eq!(c.get(""), None, "the header is no entry");
    }

    #[test]
    fn placeholders_fill_and_translate_their_parts() {
        let c = Catalogue::from_po(PO).unwrap();
        assert_eq!(c.tr("soft limit X: 12.500 mm"), "Software-Endlage X: 12.500 mm");
        assert_eq!(
            c.tr("referencing Y failed: the drive did not start homing"),
            "Referenzieren Y fehlgeschlagen: der Antrieb hat die Referenzfahrt nicht begonnen"
        );
        assert_eq!(c.get("soft limit X:"), None, "a gap is never empty");
        assert_eq!(c.get("a soft limit X: 1 mm"), None);
    }

    #[test]
    fn refuses_what_it_does_not_read() {
        let twice = "msgid \"a\"\nmsgstr \"b\"\nmsgid \"a\"\nmsgstr \"c\"\n";
        assert!(parse_po(twice).unwrap_err().what.contains("twice"));
        let slots = "msgid \"a {0}\"\nmsgstr \"b {1}\"\n";
        assert!(parse_po(slots).unwrap_err().what.contains("placeholders"));
        assert_eq!(parse_po("msgctxt \"x\"\n").unwrap_err().line, 1);
        assert!(parse_po("msgstr \"x\"\n").is_err());
        assert!(parse_po("msgid \"a\\q\"\nmsgstr \"b\"\n").is_err());
    }

    #[test]
    fn german_catalogue_reads() {
        let c = Catalogue::from_po(DE_PO).unwrap_or_else(|e| panic!("lang/de.po: {e}"));
        assert!(c.exact.len() > 100, "{} entries", c.exact.len());
    }

    #[test]
    fn languages_by_code() {
        for (i, l) in Lang::ALL.into_iter().enumerate() {
            assert_eq!(Lang::parse(l.code()), Some(l));
            assert_eq!(l as usize, i);
        }
        assert_eq!(Lang::parse("fr"), None);
    }
}
