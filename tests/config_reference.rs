//! The scene-file reference (config/README.md) against the scene structs, so that the two
//! cannot drift: every documented default is the serde default, every required key is
//! required, every documented key exists, every key of the scene structs is documented,
//! and every shipped scene is listed.
//!
//! The reference has one Markdown table per TOML table under a `### ` heading naming it
//! (`[domain]`, `[[tissue]]`, `[tool.shape]` followed by its variant tag such as
//! `type = "sphere"`; `### Top level` for the keys outside any table), with the columns
//! key | type, unit | range | default | meaning. A default is a TOML value in backticks,
//! `required (example)`, `absent (example)` for an optional key without default, or
//! `see ...` for a table whose own keys carry the defaults.

use dvrk_tissue_sim::config::{
    Arm, Domain, Keyframe, Material, Outputs, Scene, Solver, Table, TeleopSettings, Thread, Tissue,
    Tool,
};
use dvrk_tissue_sim::render::CameraSettings;
use dvrk_tissue_sim::sleep::SleepSettings;
use dvrk_tissue_sim::tools::JawGains;
use serde::de::{Deserialize, Error as _, Visitor};
use std::collections::{BTreeMap, BTreeSet};
use toml::Value;

const REFERENCE: &str = include_str!("../config/README.md");

#[derive(Clone, Debug)]
enum Documented {
    /// The key's serde default.
    Value(Value),
    /// Deserialisation fails without the key; the example (none for a table) is used to
    /// build scenes.
    Required(Option<Value>),
    /// Optional without a default: absent after deserialisation; the example sets it.
    Absent(Option<Value>),
    /// A table whose own keys carry the defaults.
    SeeTable,
}

#[derive(Clone, Debug)]
struct Key {
    name: String,
    default: Documented,
    line: usize,
}

#[derive(Clone, Debug)]
struct DocTable {
    path: Vec<String>,
    array: bool,
    /// The variant's tag key and value, for an internally tagged enum.
    variant: Option<(String, String)>,
    keys: Vec<Key>,
    line: usize,
}

impl DocTable {
    fn name(&self) -> String {
        let path = self.path.join(".");
        match &self.variant {
            Some((k, v)) => format!("[{path}] {k} = {v:?}"),
            None if path.is_empty() => "top level".into(),
            None => format!("[{path}]"),
        }
    }
}

fn backticked(text: &str) -> Vec<&str> {
    text.split('`').skip(1).step_by(2).collect()
}

fn literal(text: &str, line: usize) -> Value {
    let doc: toml::Table = toml::from_str(&format!("v = {text}"))
        .unwrap_or_else(|e| panic!("config/README.md:{line}: `{text}` is not a TOML value: {e}"));
    doc["v"].clone()
}

fn parse_default(cell: &str, line: usize) -> Documented {
    if cell.starts_with("see ") {
        return Documented::SeeTable;
    }
    let example = backticked(cell).first().map(|t| literal(t, line));
    if cell.starts_with("required") {
        Documented::Required(example)
    } else if cell.starts_with("absent") {
        Documented::Absent(example)
    } else {
        Documented::Value(example.unwrap_or_else(|| {
            panic!("config/README.md:{line}: default `{cell}` is no TOML value in backticks")
        }))
    }
}

fn parse_reference() -> Vec<DocTable> {
    let mut tables: Vec<DocTable> = Vec::new();
    let mut current: Option<DocTable> = None;
    for (i, text) in REFERENCE.lines().enumerate() {
        let line = i + 1;
        if let Some(heading) = text.strip_prefix("### ") {
            tables.extend(current.take());
            let spans = backticked(heading);
            current = match spans.first() {
                Some(span) if span.starts_with('[') => {
                    let array = span.starts_with("[[");
                    let path = span.trim_matches(|c| c == '[' || c == ']');
                    let variant = spans.get(1).map(|tag| {
                        let (k, v) = tag
                            .split_once('=')
                            .expect("a variant tag `key = \"value\"`");
                        (k.trim().to_string(), v.trim().trim_matches('"').to_string())
                    });
                    Some(DocTable {
                        path: path.split('.').map(str::to_string).collect(),
                        array,
                        variant,
                        keys: Vec::new(),
                        line,
                    })
                }
                _ if heading.trim() == "Top level" => Some(DocTable {
                    path: Vec::new(),
                    array: false,
                    variant: None,
                    keys: Vec::new(),
                    line,
                }),
                _ => None,
            };
        } else if text.starts_with("## ") {
            tables.extend(current.take());
        } else if let (Some(table), Some(row)) = (current.as_mut(), text.strip_prefix('|')) {
            let cells: Vec<&str> = row.split('|').map(str::trim).collect();
            if cells[0] == "key" || cells[0].starts_with("---") {
                continue;
            }
            assert!(
                cells.len() >= 5,
                "config/README.md:{line}: a row of key | type, unit | range | default | meaning"
            );
            let name = cells[0].trim_matches('`').to_string();
            table.keys.push(Key {
                name,
                default: parse_default(cells[3], line),
                line,
            });
        }
    }
    tables.extend(current);
    tables
}

/// The table at `path` in `doc`, created where missing (the first element of an array of
/// tables).
fn table_at<'a>(
    doc: &'a mut toml::Table,
    path: &[String],
    arrays: &BTreeSet<Vec<String>>,
) -> &'a mut toml::Table {
    let mut table = doc;
    for (depth, key) in path.iter().enumerate() {
        let slot = if arrays.contains(&path[..=depth].to_vec()) {
            let array = table
                .entry(key.clone())
                .or_insert_with(|| Value::Array(vec![Value::Table(toml::Table::new())]));
            let array = array.as_array_mut().expect("an array of tables");
            if array.is_empty() {
                array.push(Value::Table(toml::Table::new()));
            }
            &mut array[0]
        } else {
            table
                .entry(key.clone())
                .or_insert_with(|| Value::Table(toml::Table::new()))
        };
        table = slot.as_table_mut().expect("a table");
    }
    table
}

/// The serialised table at `path` (first elements of arrays), if there is one.
fn serialised_at<'a>(value: &'a Value, path: &[String]) -> Option<&'a toml::Table> {
    let mut value = value;
    for key in path {
        value = value.as_table()?.get(key)?;
        if let Value::Array(items) = value {
            value = items.first()?;
        }
    }
    value.as_table()
}

struct Reference {
    tables: Vec<DocTable>,
    arrays: BTreeSet<Vec<String>>,
}

impl Reference {
    fn load() -> Reference {
        let tables = parse_reference();
        let arrays = tables
            .iter()
            .filter(|t| t.array)
            .map(|t| t.path.clone())
            .collect();
        Reference { tables, arrays }
    }

    /// A scene document with every documented table: the required keys at their examples,
    /// and with `with_absent` the optional keys without default at theirs too. Tagged
    /// tables take the variant `chosen` where it names one of their path, else the first
    /// documented.
    fn scene(&self, chosen: Option<&DocTable>, with_absent: bool) -> toml::Table {
        let mut doc = toml::Table::new();
        let mut done: BTreeSet<Vec<String>> = BTreeSet::new();
        for table in &self.tables {
            let table = match chosen {
                Some(c) if c.path == table.path => c,
                _ => table,
            };
            if !done.insert(table.path.clone()) {
                continue;
            }
            let target = table_at(&mut doc, &table.path, &self.arrays);
            if let Some((tag, value)) = &table.variant {
                target.insert(tag.clone(), Value::String(value.clone()));
            }
            for key in &table.keys {
                match &key.default {
                    Documented::Required(Some(example)) => {
                        target.insert(key.name.clone(), example.clone());
                    }
                    Documented::Absent(Some(example)) if with_absent => {
                        target.insert(key.name.clone(), example.clone());
                    }
                    _ => {}
                }
            }
        }
        doc
    }
}

fn deserialise(doc: &toml::Table) -> Result<Scene, String> {
    let text = toml::to_string(doc).expect("a scene document serialises");
    toml::from_str::<Scene>(&text).map_err(|e| e.to_string())
}

fn serialised(scene: &Scene) -> Value {
    Value::try_from(scene).expect("a scene serialises")
}

fn same(a: &Value, b: &Value) -> bool {
    let number = |v: &Value| match v {
        Value::Integer(i) => Some(*i as f64),
        Value::Float(f) => Some(*f),
        _ => None,
    };
    match (a, b) {
        (Value::Array(a), Value::Array(b)) => {
            a.len() == b.len() && a.iter().zip(b).all(|(a, b)| same(a, b))
        }
        (Value::Table(a), Value::Table(b)) => {
            a.len() == b.len() && a.iter().all(|(k, v)| b.get(k).is_some_and(|w| same(v, w)))
        }
        _ => match (number(a), number(b)) {
            // Defaults kept in f32 come back as the nearest f32.
            (Some(x), Some(y)) => (x - y).abs() <= 1e-6 * x.abs().max(y.abs()),
            _ => a == b,
        },
    }
}

/// Records the field names serde asks a struct's deserializer for.
struct FieldNames<'a>(&'a mut Vec<&'static str>);

impl<'de> serde::Deserializer<'de> for FieldNames<'_> {
    type Error = serde::de::value::Error;

    fn deserialize_any<V: Visitor<'de>>(self, _: V) -> Result<V::Value, Self::Error> {
        Err(Self::Error::custom("not a struct"))
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        fields: &'static [&'static str],
        _: V,
    ) -> Result<V::Value, Self::Error> {
        self.0.extend(fields);
        Err(Self::Error::custom("fields read"))
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf
        option unit unit_struct newtype_struct seq tuple tuple_struct map enum identifier
        ignored_any
    }
}

fn fields<T: for<'de> Deserialize<'de>>() -> BTreeSet<String> {
    let mut names = Vec::new();
    let _ = T::deserialize(FieldNames(&mut names));
    names.into_iter().map(str::to_string).collect()
}

/// The keys of every scene struct, by the path of the TOML table it is read from.
fn struct_keys() -> BTreeMap<String, BTreeSet<String>> {
    [
        ("", fields::<Scene>()),
        ("domain", fields::<Domain>()),
        ("solver", fields::<Solver>()),
        ("table", fields::<Table>()),
        ("tissue", fields::<Tissue>()),
        ("tissue.material", fields::<Material>()),
        ("thread", fields::<Thread>()),
        ("tool", fields::<Tool>()),
        ("tool.jaw", fields::<JawGains>()),
        ("tool.keyframe", fields::<Keyframe>()),
        ("arm", fields::<Arm>()),
        ("teleop", fields::<TeleopSettings>()),
        ("outputs", fields::<Outputs>()),
        ("sleep", fields::<SleepSettings>()),
        ("camera", fields::<CameraSettings>()),
    ]
    .into_iter()
    .map(|(path, keys)| {
        assert!(!keys.is_empty(), "no fields read for `{path}`");
        (path.to_string(), keys)
    })
    .collect()
}

/// The variants serde knows for the tagged table at `path`, read from its error for an
/// unknown tag.
fn variants(reference: &Reference, path: &[String], tag: &str) -> BTreeSet<String> {
    let mut doc = reference.scene(None, false);
    let table = table_at(&mut doc, path, &reference.arrays);
    table.clear();
    table.insert(tag.into(), Value::String("no_such_variant".into()));
    let error = deserialise(&doc).expect_err("an unknown variant is refused");
    // "unknown variant `x`, expected `a` or `b`" or "..., expected one of `a`, `b`, `c`".
    let line = error
        .lines()
        .find(|l| l.contains("unknown variant"))
        .unwrap_or_else(|| panic!("no unknown-variant message in {error:?}"));
    let expected = line
        .split_once("expected")
        .unwrap_or_else(|| panic!("no variant list in {line:?}"))
        .1;
    backticked(expected)
        .into_iter()
        .map(str::to_string)
        .collect()
}

#[test]
fn the_reference_documents_every_table_of_the_scene_structs() {
    let reference = Reference::load();
    let documented: BTreeSet<String> = reference
        .tables
        .iter()
        .filter(|t| t.variant.is_none())
        .map(|t| t.path.join("."))
        .collect();
    let structs: BTreeSet<String> = struct_keys().into_keys().collect();
    let tagged: BTreeSet<String> = reference
        .tables
        .iter()
        .filter(|t| t.variant.is_some())
        .map(|t| t.path.join("."))
        .collect();
    assert_eq!(
        documented, structs,
        "config/README.md's untagged tables against the scene structs"
    );
    assert_eq!(
        tagged,
        BTreeSet::from(["tool.contact".to_string(), "tool.shape".to_string()]),
        "config/README.md's tagged tables"
    );
    for path in &tagged {
        let tables: Vec<&DocTable> = reference
            .tables
            .iter()
            .filter(|t| t.path.join(".") == *path)
            .collect();
        let tag = &tables[0].variant.as_ref().unwrap().0;
        let documented: BTreeSet<String> = tables
            .iter()
            .map(|t| t.variant.as_ref().unwrap().1.clone())
            .collect();
        assert_eq!(
            documented,
            variants(&reference, &tables[0].path, tag),
            "variants of [{path}] documented in config/README.md against the code's"
        );
    }
}

#[test]
fn every_documented_key_exists_and_every_key_is_documented() {
    let reference = Reference::load();
    let structs = struct_keys();
    for table in &reference.tables {
        let documented: BTreeSet<String> = table.keys.iter().map(|k| k.name.clone()).collect();
        assert_eq!(
            documented.len(),
            table.keys.len(),
            "config/README.md:{}: a key documented twice in {}",
            table.line,
            table.name()
        );
        // Every documented key set at once: unknown keys are refused (deny_unknown_fields).
        let doc = reference.scene(Some(table), true);
        let scene = deserialise(&doc).unwrap_or_else(|e| {
            panic!(
                "config/README.md:{}: {} with every documented key set does not parse: {e}",
                table.line,
                table.name()
            )
        });
        let value = serialised(&scene);
        let back = serialised_at(&value, &table.path)
            .unwrap_or_else(|| panic!("{} is not in the serialised scene", table.name()));
        let mut keys: BTreeSet<String> = back.keys().cloned().collect();
        if let Some((tag, _)) = &table.variant {
            keys.remove(tag);
        }
        if let Some(fields) = structs.get(&table.path.join(".")) {
            keys.extend(fields.iter().cloned());
        }
        assert_eq!(
            documented,
            keys,
            "config/README.md:{}: the keys of {} against the scene structs",
            table.line,
            table.name()
        );
    }
}

#[test]
fn every_documented_default_is_the_code_default() {
    let reference = Reference::load();
    let mut checked = 0;
    for table in &reference.tables {
        for key in &table.keys {
            let mut doc = reference.scene(Some(table), false);
            table_at(&mut doc, &table.path, &reference.arrays).remove(&key.name);
            let parsed = deserialise(&doc);
            let at = format!(
                "config/README.md:{}: {}.{}",
                key.line,
                table.name(),
                key.name
            );
            match &key.default {
                Documented::Required(_) => {
                    let error = parsed.err().unwrap_or_else(|| {
                        panic!("{at} is documented as required but a scene without it parses")
                    });
                    assert!(
                        error.contains(&format!("missing field `{}`", key.name)),
                        "{at}: without it the scene is refused for another reason: {error}"
                    );
                }
                Documented::Value(expected) => {
                    let scene = parsed.unwrap_or_else(|e| panic!("{at}: no scene without it: {e}"));
                    let value = serialised(&scene);
                    let actual = serialised_at(&value, &table.path)
                        .and_then(|t| t.get(&key.name))
                        .unwrap_or_else(|| panic!("{at}: not in the serialised scene"));
                    assert!(
                        same(actual, expected),
                        "{at}: documented default {expected} but the code's is {actual}"
                    );
                }
                Documented::Absent(_) => {
                    let scene = parsed.unwrap_or_else(|e| panic!("{at}: no scene without it: {e}"));
                    let value = serialised(&scene);
                    let actual = serialised_at(&value, &table.path).and_then(|t| t.get(&key.name));
                    assert!(
                        actual.is_none(),
                        "{at}: documented as absent by default but the code gives {actual:?}"
                    );
                }
                Documented::SeeTable => {
                    parsed.unwrap_or_else(|e| panic!("{at}: no scene without it: {e}"));
                }
            }
            checked += 1;
        }
    }
    assert!(
        checked > 100,
        "only {checked} keys read from config/README.md"
    );
}

#[test]
fn the_reference_lists_every_shipped_scene() {
    let listed: BTreeSet<String> = REFERENCE
        .lines()
        .filter_map(|l| l.strip_prefix("- `"))
        .filter_map(|l| l.split('`').next())
        .filter(|name| name.ends_with(".toml"))
        .map(str::to_string)
        .collect();
    let shipped: BTreeSet<String> =
        std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/config"))
            .expect("config/ is readable")
            .map(|e| e.expect("a directory entry").file_name())
            .map(|n| n.to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".toml"))
            .collect();
    assert_eq!(
        listed, shipped,
        "scenes listed in config/README.md against config/*.toml"
    );
}
