//! `docs/reference/` against the code, so the reference cannot drift:
//!
//! - `config.md`: the keys documented (its table rows `` | `[node] velocity_scale` | … ``)
//!   are exactly the keys the config types accept — read from the types themselves by a
//!   tracing `serde::Deserializer` ([`schema`]), which asks `Config`'s derived `Deserialize`
//!   for every struct's field names and every enum's variants (internally tagged enums,
//!   whose derived code names nothing to a deserializer, through samples per variant,
//!   themselves checked complete against serde's refusals of an unknown kind and an unknown
//!   field); the allowed values of every enum-valued key appear in its row; every shipped
//!   `config/*.toml` loads and uses documented keys only.
//! - `cli.md`: every command's `--help`, regenerated from the binary and compared
//!   (`CROSSYM_BLESS=1 cargo test --test integration reference::` rewrites it).
//! - `messages.md`: every field and constant of `msgs/msg/*.msg` is documented.
//! - `crossym --version`: `crossym <version> (<git hash>)`, the hash of HEAD.

use std::collections::{BTreeMap, BTreeSet};

use crate::common;

/// `docs/reference/NAME`.
fn reference(name: &str) -> String {
    let p = common::path(&format!("docs/reference/{name}"));
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The first cell of every table row whose first cell is a code span starting with `[`:
/// the documented key (`[node] velocity_scale`) and the whole row.
fn documented_keys(md: &str) -> BTreeMap<String, String> {
    md.lines()
        .filter_map(|l| {
            let rest = l.strip_prefix("| `[")?;
            let end = rest.find('`')?;
            Some((format!("[{}", &rest[..end]), l.to_string()))
        })
        .collect()
}

/// The tables config.md documents by another's keys: a heading
/// `` ### `[alias]` — same keys as `[canonical]` `` gives `(alias, canonical)` without brackets.
fn same_keys(md: &str) -> Vec<(String, String)> {
    md.lines()
        .filter(|l| l.starts_with('#') && l.contains("same keys as"))
        .map(|l| {
            let spans: Vec<&str> = l.split('`').skip(1).step_by(2).collect();
            assert!(spans.len() >= 2, "config.md: which tables? {l}");
            let bare = |s: &str| s.trim_matches(['[', ']']).to_string();
            (bare(spans[0]), bare(spans[1]))
        })
        .collect()
}

/// The accepted keys of the configuration files, from the config types' `Deserialize`.
mod schema {
    use std::cell::RefCell;
    use std::collections::{BTreeMap, BTreeSet};
    use std::fmt;

    use serde::de::{
        self, DeserializeSeed, Deserializer, EnumAccess, IntoDeserializer, MapAccess, SeqAccess,
        VariantAccess, Visitor,
    };

    /// Where `deserialize_any` is asked for (an internally tagged or untagged enum: the
    /// derived code does not name its fields to the deserializer), the values to offer, one
    /// per variant (TOML); their keys are the documented ones. A new spot fails the trace
    /// with its path; a new variant or field of a tagged enum fails [`super::config_keys`]'s
    /// probes.
    pub const SAMPLES: &[(&str, &[&str])] = &[
        (
            "symmetries[].group",
            &[
                r#"{ kind = "morphological", chains = ["l", "r"], plane_normal = [0.0, 1.0, 0.0], signs = [1.0], whole_body = false }"#,
                r#"{ kind = "so2", axis = [0.0, 0.0, 1.0] }"#,
                r#"{ kind = "so3" }"#,
                r#"{ kind = "scaling" }"#,
                r#"{ kind = "translation", directions = [[1.0, 0.0]] }"#,
                r#"{ kind = "task_induced", cost = { kind = "distance_to_point", point = [0.0, 0.0] } }"#,
                r#"{ kind = "task_induced", cost = { kind = "distance_to_line", point = [0.0, 0.0], direction = [1.0, 0.0] } }"#,
                r#"{ kind = "task_induced", cost = { kind = "height_above_plane", point = [0.0, 0.0], normal = [0.0, 1.0] } }"#,
                r#"{ kind = "task_induced", cost = { kind = "sum", terms = [] } }"#,
            ],
        ),
        ("demonstrations.train[]", &["1", r#""name""#]),
        ("demonstrations.test[]", &["1", r#""name""#]),
        ("letters.train[]", &["1", r#""name""#]),
        ("letters.test[]", &["1", r#""name""#]),
        (
            "demonstrations.cleaning.differentiator",
            &[
                r#"{ kind = "savitzky_golay", half_window = 7, order = 2 }"#,
                r#"{ kind = "finite_difference" }"#,
            ],
        ),
        (
            "train.lr_schedule",
            &[
                r#"{ kind = "constant" }"#,
                r#"{ kind = "cosine", final_learning_rate = 1e-5 }"#,
            ],
        ),
        (
            "train_task_head.lr_schedule",
            &[
                r#"{ kind = "constant" }"#,
                r#"{ kind = "cosine", final_learning_rate = 1e-5 }"#,
            ],
        ),
        (
            "eval.paper_protocol",
            &[
                r#"{ kind = "pooled", warmup_samples = 60 }"#,
                r#"{ kind = "resampled", points = 200, columns = "task" }"#,
            ],
        ),
    ];

    /// One step of a key's path.
    #[derive(Debug, Clone, PartialEq)]
    pub enum Seg {
        /// A struct field or table key.
        Field(String),
        /// An element of an array.
        Seq,
        /// The key of a map (`[robot.limits.<name>]`).
        Key,
        /// The variant of an externally tagged enum.
        Variant(String),
    }

    /// The path as [`SAMPLES`] names it: `symmetries[].group`.
    pub fn dotted(path: &[Seg]) -> String {
        let mut s = String::new();
        for seg in path {
            match seg {
                Seg::Field(n) | Seg::Variant(n) => {
                    if !s.is_empty() {
                        s.push('.');
                    }
                    s.push_str(n);
                }
                Seg::Seq => s.push_str("[]"),
                Seg::Key => s.push_str(".<name>"),
            }
        }
        s
    }

    /// The table header of a path: `[node.safety]`, `[[symmetries]]`,
    /// `[robot.limits.<name>]`.
    pub fn table(path: &[Seg]) -> String {
        let names: Vec<&str> = path
            .iter()
            .filter_map(|s| match s {
                Seg::Field(n) | Seg::Variant(n) => Some(n.as_str()),
                Seg::Key => Some("<name>"),
                Seg::Seq => None,
            })
            .collect();
        if matches!(path.last(), Some(Seg::Seq)) {
            format!("[[{}]]", names.join("."))
        } else {
            format!("[{}]", names.join("."))
        }
    }

    /// The documented form of a leaf's path: `[node.safety] margin`, `[robot.held] <name>`
    /// (an array of values is a leaf: its trailing `[]` go).
    pub fn key(path: &[Seg]) -> String {
        let mut p = path;
        while let Some((Seg::Seq, rest)) = p.split_last() {
            p = rest;
        }
        let (last, parent) = p.split_last().expect("a leaf below the top level");
        let name = match last {
            Seg::Field(n) | Seg::Variant(n) => n.clone(),
            Seg::Key => "<name>".into(),
            Seg::Seq => unreachable!(),
        };
        format!("{} {name}", table(parent))
    }

    /// What a trace found.
    #[derive(Debug, Default)]
    pub struct Schema {
        /// Documented key → the values it allows when it is an enum (empty: any value of
        /// its type).
        pub leaves: BTreeMap<String, BTreeSet<String>>,
        /// Table headers.
        pub tables: BTreeSet<String>,
    }

    #[derive(Debug, Default)]
    struct State {
        pass: usize,
        /// Most alternatives at one choice point (enum variants, samples): passes needed.
        widest: usize,
        schema: Schema,
        /// A probe: this TOML instead of the samples at this path.
        probe: Option<(String, String)>,
    }

    impl State {
        fn choose(&mut self, n: usize) -> usize {
            self.widest = self.widest.max(n);
            self.pass.min(n.saturating_sub(1))
        }

        fn leaf(&mut self, path: &[Seg], values: &[&str]) {
            self.schema
                .leaves
                .entry(key(path))
                .or_default()
                .extend(values.iter().map(|v| v.to_string()));
        }

        /// Records the keys of a TOML sample offered at `path`.
        fn sample_keys(&mut self, path: &[Seg], v: &toml::Value) {
            match v {
                toml::Value::Table(t) => {
                    self.schema.tables.insert(table(path));
                    for (k, v) in t {
                        let mut p = path.to_vec();
                        p.push(Seg::Field(k.clone()));
                        match v {
                            toml::Value::Array(a)
                                if !a.is_empty() && a.iter().all(|e| e.is_table()) =>
                            {
                                p.push(Seg::Seq);
                                for e in a {
                                    self.sample_keys(&p, e);
                                }
                            }
                            toml::Value::Table(_) => self.sample_keys(&p, v),
                            toml::Value::String(s) if k == "kind" => self.leaf(&p, &[s]),
                            _ => self.leaf(&p, &[]),
                        }
                    }
                }
                _ => self.leaf(path, &[]),
            }
        }
    }

    /// Errors of the trace (a probe's refusal is one).
    #[derive(Debug)]
    pub struct Error(pub String);

    impl fmt::Display for Error {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str(&self.0)
        }
    }

    impl std::error::Error for Error {}

    impl de::Error for Error {
        fn custom<T: fmt::Display>(msg: T) -> Self {
            Error(msg.to_string())
        }
    }

    /// The tracing deserializer at one path: offers a value of whatever type is asked for,
    /// and records struct fields, enum variants and leaves on the way.
    struct Tracer<'a> {
        state: &'a RefCell<State>,
        path: Vec<Seg>,
    }

    impl<'a> Tracer<'a> {
        fn at(&self, seg: Seg) -> Tracer<'a> {
            let mut path = self.path.clone();
            path.push(seg);
            assert!(path.len() < 24, "runaway recursion at {}", dotted(&path));
            Tracer {
                state: self.state,
                path,
            }
        }

        fn leaf(&self) {
            self.state.borrow_mut().leaf(&self.path, &[]);
        }
    }

    macro_rules! leaf {
        ($($method:ident => $visit:ident($($value:expr)?)),* $(,)?) => {
            $(fn $method<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
                self.leaf();
                visitor.$visit($($value)?)
            })*
        };
    }

    impl<'de> Deserializer<'de> for Tracer<'_> {
        type Error = Error;

        leaf! {
            deserialize_bool => visit_bool(false),
            deserialize_i8 => visit_u64(1),
            deserialize_i16 => visit_u64(1),
            deserialize_i32 => visit_u64(1),
            deserialize_i64 => visit_u64(1),
            deserialize_u8 => visit_u64(1),
            deserialize_u16 => visit_u64(1),
            deserialize_u32 => visit_u64(1),
            deserialize_u64 => visit_u64(1),
            deserialize_f32 => visit_f64(1.0),
            deserialize_f64 => visit_f64(1.0),
            deserialize_char => visit_char('x'),
            deserialize_str => visit_str("x"),
            deserialize_string => visit_str("x"),
            deserialize_bytes => visit_bytes(b"x"),
            deserialize_byte_buf => visit_bytes(b"x"),
            deserialize_unit => visit_unit(),
            deserialize_identifier => visit_str("x"),
            deserialize_ignored_any => visit_unit(),
        }

        fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
            let here = dotted(&self.path);
            let text = {
                let mut st = self.state.borrow_mut();
                match &st.probe {
                    Some((p, t)) if *p == here => t.clone(),
                    _ => {
                        let Some((_, samples)) = SAMPLES.iter().find(|(p, _)| *p == here) else {
                            return Err(Error(format!(
                                "`{here}`: the type asks for deserialize_any (an internally \
                                 tagged or untagged enum); add a sample per variant to \
                                 reference::schema::SAMPLES"
                            )));
                        };
                        let i = st.choose(samples.len());
                        samples[i].to_string()
                    }
                }
            };
            let value = toml::from_str::<toml::Table>(&format!("v = {text}"))
                .map_err(|e| Error(format!("sample at `{here}`: {e}")))?
                .remove("v")
                .expect("v");
            self.state.borrow_mut().sample_keys(&self.path, &value);
            value
                .deserialize_any(visitor)
                .map_err(|e| Error(format!("sample at `{here}`: {e}")))
        }

        fn deserialize_option<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
            visitor.visit_some(self)
        }

        fn deserialize_unit_struct<V: Visitor<'de>>(
            self,
            _name: &'static str,
            visitor: V,
        ) -> Result<V::Value, Error> {
            self.leaf();
            visitor.visit_unit()
        }

        fn deserialize_newtype_struct<V: Visitor<'de>>(
            self,
            _name: &'static str,
            visitor: V,
        ) -> Result<V::Value, Error> {
            visitor.visit_newtype_struct(self)
        }

        fn deserialize_seq<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
            visitor.visit_seq(Elements {
                of: self.at(Seg::Seq),
                left: 1,
            })
        }

        fn deserialize_tuple<V: Visitor<'de>>(
            self,
            len: usize,
            visitor: V,
        ) -> Result<V::Value, Error> {
            visitor.visit_seq(Elements {
                of: self.at(Seg::Seq),
                left: len,
            })
        }

        fn deserialize_tuple_struct<V: Visitor<'de>>(
            self,
            _name: &'static str,
            len: usize,
            visitor: V,
        ) -> Result<V::Value, Error> {
            self.deserialize_tuple(len, visitor)
        }

        fn deserialize_map<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
            self.state
                .borrow_mut()
                .schema
                .tables
                .insert(table(&self.path));
            visitor.visit_map(OneEntry {
                value: Some(self.at(Seg::Key)),
            })
        }

        fn deserialize_struct<V: Visitor<'de>>(
            self,
            _name: &'static str,
            fields: &'static [&'static str],
            visitor: V,
        ) -> Result<V::Value, Error> {
            self.state
                .borrow_mut()
                .schema
                .tables
                .insert(table(&self.path));
            visitor.visit_map(Fields {
                of: self,
                fields,
                next: 0,
            })
        }

        fn deserialize_enum<V: Visitor<'de>>(
            self,
            _name: &'static str,
            variants: &'static [&'static str],
            visitor: V,
        ) -> Result<V::Value, Error> {
            let i = self.state.borrow_mut().choose(variants.len());
            visitor.visit_enum(Variant {
                of: self,
                variants,
                chosen: variants[i],
            })
        }
    }

    struct Elements<'a> {
        of: Tracer<'a>,
        left: usize,
    }

    impl<'de> SeqAccess<'de> for Elements<'_> {
        type Error = Error;
        fn next_element_seed<T: DeserializeSeed<'de>>(
            &mut self,
            seed: T,
        ) -> Result<Option<T::Value>, Error> {
            if self.left == 0 {
                return Ok(None);
            }
            self.left -= 1;
            seed.deserialize(Tracer {
                state: self.of.state,
                path: self.of.path.clone(),
            })
            .map(Some)
        }
    }

    struct OneEntry<'a> {
        value: Option<Tracer<'a>>,
    }

    impl<'de> MapAccess<'de> for OneEntry<'_> {
        type Error = Error;
        fn next_key_seed<K: DeserializeSeed<'de>>(
            &mut self,
            seed: K,
        ) -> Result<Option<K::Value>, Error> {
            if self.value.is_none() {
                return Ok(None);
            }
            seed.deserialize(IntoDeserializer::<Error>::into_deserializer("name"))
                .map(Some)
        }
        fn next_value_seed<T: DeserializeSeed<'de>>(&mut self, seed: T) -> Result<T::Value, Error> {
            seed.deserialize(self.value.take().expect("a key first"))
        }
    }

    struct Fields<'a> {
        of: Tracer<'a>,
        fields: &'static [&'static str],
        next: usize,
    }

    impl<'de> MapAccess<'de> for Fields<'_> {
        type Error = Error;
        fn next_key_seed<K: DeserializeSeed<'de>>(
            &mut self,
            seed: K,
        ) -> Result<Option<K::Value>, Error> {
            match self.fields.get(self.next) {
                Some(f) => seed
                    .deserialize(IntoDeserializer::<Error>::into_deserializer(*f))
                    .map(Some),
                None => Ok(None),
            }
        }
        fn next_value_seed<T: DeserializeSeed<'de>>(&mut self, seed: T) -> Result<T::Value, Error> {
            let f = self.fields[self.next];
            self.next += 1;
            seed.deserialize(self.of.at(Seg::Field(f.to_string())))
        }
    }

    struct Variant<'a> {
        of: Tracer<'a>,
        variants: &'static [&'static str],
        chosen: &'static str,
    }

    impl<'de, 'a> EnumAccess<'de> for Variant<'a> {
        type Error = Error;
        type Variant = Variant<'a>;
        fn variant_seed<V: DeserializeSeed<'de>>(self, seed: V) -> Result<(V::Value, Self), Error> {
            let v = seed.deserialize(IntoDeserializer::<Error>::into_deserializer(self.chosen))?;
            Ok((v, self))
        }
    }

    impl<'de> VariantAccess<'de> for Variant<'_> {
        type Error = Error;
        fn unit_variant(self) -> Result<(), Error> {
            self.of
                .state
                .borrow_mut()
                .leaf(&self.of.path, self.variants);
            Ok(())
        }
        fn newtype_variant_seed<T: DeserializeSeed<'de>>(self, seed: T) -> Result<T::Value, Error> {
            seed.deserialize(self.of.at(Seg::Variant(self.chosen.into())))
        }
        fn tuple_variant<V: Visitor<'de>>(self, len: usize, visitor: V) -> Result<V::Value, Error> {
            self.of
                .at(Seg::Variant(self.chosen.into()))
                .deserialize_tuple(len, visitor)
        }
        fn struct_variant<V: Visitor<'de>>(
            self,
            fields: &'static [&'static str],
            visitor: V,
        ) -> Result<V::Value, Error> {
            self.of
                .at(Seg::Variant(self.chosen.into()))
                .deserialize_struct("", fields, visitor)
        }
    }

    /// Every key of [`crossym::config::Config`]: passes until every enum variant and every
    /// sample has been offered once.
    pub fn trace() -> Result<Schema, Error> {
        let state = RefCell::new(State::default());
        loop {
            serde::Deserialize::deserialize(Tracer {
                state: &state,
                path: Vec::new(),
            })
            .map(|_: crossym::config::Config| ())?;
            let mut st = state.borrow_mut();
            st.pass += 1;
            if st.pass >= st.widest {
                break;
            }
        }
        Ok(state.into_inner().schema)
    }

    /// One pass with `text` offered at `path` (one of [`SAMPLES`]' paths): the refusal.
    pub fn probe(path: &str, text: &str) -> Result<(), Error> {
        let state = RefCell::new(State {
            probe: Some((path.into(), text.into())),
            ..State::default()
        });
        serde::Deserialize::deserialize(Tracer {
            state: &state,
            path: Vec::new(),
        })
        .map(|_: crossym::config::Config| ())
    }
}

/// A tagged table of the samples: one sample holding it, and the kinds the samples give it.
type KindsSeen = (toml::Value, BTreeSet<String>);

/// A TOML value written inline.
fn toml_value(text: &str) -> toml::Value {
    toml::from_str::<toml::Table>(&format!("v = {text}")).expect("TOML value")["v"].clone()
}

/// The tables with a `kind` key in `v` (itself included), by their key path.
fn tagged_tables(v: &toml::Value, at: Vec<String>) -> Vec<(Vec<String>, toml::Table)> {
    let Some(t) = v.as_table() else {
        return Vec::new();
    };
    let mut out = Vec::new();
    if t.contains_key("kind") {
        out.push((at.clone(), t.clone()));
    }
    for (k, v) in t {
        let mut p = at.clone();
        p.push(k.clone());
        out.extend(tagged_tables(v, p));
    }
    out
}

/// The table at key path `at` in `v`.
fn table_at<'a>(v: &'a mut toml::Value, at: &[String]) -> &'a mut toml::Table {
    let t = v.as_table_mut().expect("a table");
    match at.split_first() {
        None => t,
        Some((k, rest)) => table_at(t.get_mut(k).expect("key"), rest),
    }
}

/// The backticked names after `expected` in serde's refusal (`expected one of `a`, `b``,
/// `expected `a``, `there are no fields`).
fn expected_names(message: &str) -> BTreeSet<String> {
    let Some(at) = message.find("expected") else {
        return BTreeSet::new();
    };
    let line = message[at..].lines().next().unwrap_or("");
    line.split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect()
}

#[test]
fn config_keys() {
    let schema = schema::trace().unwrap_or_else(|e| panic!("tracing Config: {e}"));
    let md = reference("config.md");
    let mut documented = documented_keys(&md);
    // `### `[train_task_head]` — same keys as `[train]``: the keys below the one table
    // are the keys below the other (checked), documented once.
    for (alias, canonical) in same_keys(&md) {
        let below = |t: &str| {
            let t = t.to_string();
            move |k: &&String| {
                let table = k.split(' ').next().unwrap_or("").trim_matches(['[', ']']);
                table == t || table.starts_with(&format!("{t}."))
            }
        };
        let renamed: BTreeSet<String> = schema
            .leaves
            .keys()
            .filter(below(&alias))
            .map(|k| k.replacen(&alias, &canonical, 1))
            .collect();
        let canon: BTreeSet<String> = schema
            .leaves
            .keys()
            .filter(below(&canonical))
            .cloned()
            .collect();
        assert!(
            !renamed.is_empty() && renamed == canon,
            "config.md says [{alias}] has the keys of [{canonical}], the types disagree:\n  \
             [{alias}]: {renamed:?}\n  [{canonical}]: {canon:?}"
        );
        for k in schema.leaves.keys().filter(below(&alias)) {
            let row = documented[&k.replacen(&alias, &canonical, 1)].clone();
            documented.insert(k.clone(), row);
        }
    }
    let accepted: BTreeSet<&String> = schema.leaves.keys().collect();
    let docs: BTreeSet<&String> = documented.keys().collect();
    let missing: Vec<_> = accepted.difference(&docs).collect();
    let stale: Vec<_> = docs.difference(&accepted).collect();
    assert!(
        missing.is_empty() && stale.is_empty(),
        "docs/reference/config.md out of date with the config types:\n  accepted but not \
         documented (add a row `| `KEY` | type | default | meaning |`): {missing:?}\n  \
         documented but not accepted: {stale:?}"
    );
    for (key, values) in &schema.leaves {
        let row = &documented[key];
        let absent: Vec<_> = values
            .iter()
            .filter(|v| !row.contains(&format!("`{v}`")) && !row.contains(&format!("`\"{v}\"`")))
            .collect();
        assert!(
            absent.is_empty(),
            "config.md row of `{key}` does not name the values {absent:?}:\n{row}"
        );
    }
    // The tagged enums offered by samples, nested ones too (`[symmetries.group.cost]`):
    // every variant, and every field of each variant where the enum denies unknown fields
    // (serde's refusal of an unknown one names them).
    let mut kinds: BTreeMap<(&str, Vec<String>), KindsSeen> = BTreeMap::new();
    for (path, samples) in schema::SAMPLES {
        for s in *samples {
            let sample = toml_value(s);
            for (at, t) in tagged_tables(&sample, Vec::new()) {
                let kind = t["kind"].as_str().expect("kind is a string").to_string();
                kinds
                    .entry((*path, at.clone()))
                    .or_insert_with(|| (sample.clone(), BTreeSet::new()))
                    .1
                    .insert(kind);
                let mut probe = sample.clone();
                table_at(&mut probe, &at).insert("__probe__".into(), 0.into());
                let refusal = schema::probe(path, &probe.to_string())
                    .err()
                    .map(|e| e.0)
                    .unwrap_or_default();
                if refusal.contains("__probe__") {
                    let fields: BTreeSet<String> =
                        t.keys().filter(|k| *k != "kind").cloned().collect();
                    assert_eq!(
                        expected_names(&refusal),
                        fields,
                        "the sample {s} at `{path}` (reference::schema::SAMPLES) does not \
                         name every field of its variant: {refusal}"
                    );
                }
            }
        }
    }
    for ((path, at), (sample, seen)) in &kinds {
        let mut probe = sample.clone();
        *table_at(&mut probe, at) = toml_value(r#"{ kind = "__probe__" }"#)
            .as_table()
            .expect("table")
            .clone();
        let refusal = schema::probe(path, &probe.to_string())
            .expect_err("an unknown kind is refused")
            .0;
        assert_eq!(
            &expected_names(&refusal),
            seen,
            "the samples at `{path}` {at:?} (reference::schema::SAMPLES) do not cover every \
             kind: {refusal}"
        );
    }
    // The shipped configurations load, with documented keys only.
    let dir = common::path("config");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .expect("config/")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    assert!(!files.is_empty());
    for f in &files {
        crossym::config::Config::from_file(f).unwrap_or_else(|e| panic!("{e}"));
        let t: toml::Table =
            toml::from_str(&std::fs::read_to_string(f).expect("read")).expect("TOML");
        let mut used = BTreeSet::new();
        shipped_keys(&schema, &mut Vec::new(), &toml::Value::Table(t), &mut used);
        let undocumented: Vec<_> = used
            .iter()
            .filter(|k| !documented.contains_key(*k))
            .collect();
        assert!(
            undocumented.is_empty(),
            "{} uses keys config.md does not document: {undocumented:?}",
            f.display()
        );
    }
}

/// The documented form of every key a TOML file sets; the keys of maps
/// (`[robot.limits.<name>]`) as `<name>`.
fn shipped_keys(
    schema: &schema::Schema,
    path: &mut Vec<schema::Seg>,
    v: &toml::Value,
    out: &mut BTreeSet<String>,
) {
    use schema::Seg;
    match v {
        toml::Value::Table(t) => {
            path.push(Seg::Key);
            let is_map = schema.tables.contains(&schema::table(path))
                || schema.leaves.contains_key(&schema::key(path));
            path.pop();
            for (k, v) in t {
                path.push(if is_map {
                    Seg::Key
                } else {
                    Seg::Field(k.clone())
                });
                match v {
                    toml::Value::Array(a) if !a.is_empty() && a.iter().all(|e| e.is_table()) => {
                        path.push(Seg::Seq);
                        for e in a {
                            shipped_keys(schema, path, e, out);
                        }
                        path.pop();
                    }
                    toml::Value::Table(_) => shipped_keys(schema, path, v, out),
                    _ => {
                        out.insert(schema::key(path));
                    }
                }
                path.pop();
            }
        }
        _ => {
            out.insert(schema::key(path));
        }
    }
}

/// A quick look at what the trace finds (`-- --ignored --nocapture`).
#[test]
#[ignore]
fn print_config_keys() {
    let schema = schema::trace().unwrap_or_else(|e| panic!("tracing Config: {e}"));
    for (k, v) in &schema.leaves {
        println!("{k}  {v:?}");
    }
    for t in &schema.tables {
        println!("table {t}");
    }
}

/// `crossym ARGS… --help`, plain (no colours; clap wraps nothing without a terminal).
fn help(args: &[&str]) -> String {
    let mut cmd = common::crossym(args.iter().chain(&["--help"]));
    cmd.env("NO_COLOR", "1")
        .env_remove("CLICOLOR_FORCE")
        .env("COLUMNS", "100");
    common::run_ok(&mut cmd)
}

/// The subcommands listed under `Commands:` in a help text (without `help`).
fn subcommands(help: &str) -> Vec<String> {
    help.lines()
        .skip_while(|l| *l != "Commands:")
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .filter(|l| l.starts_with("  ") && !l.starts_with("   "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .map(str::to_string)
        .collect()
}

/// docs/reference/cli.md as the binary's help renders it: `crossym --help` and, depth first,
/// the `--help` of every command.
fn render_cli_md() -> String {
    let mut sections = Vec::new();
    let mut todo: Vec<Vec<String>> = vec![Vec::new()];
    while let Some(args) = todo.pop() {
        let argv: Vec<&str> = args.iter().map(String::as_str).collect();
        let text = help(&argv);
        let subs = subcommands(&text);
        for s in subs.iter().rev() {
            let mut a = args.clone();
            a.push(s.clone());
            todo.push(a);
        }
        let name = std::iter::once("crossym")
            .chain(argv.iter().copied())
            .collect::<Vec<_>>()
            .join(" ");
        sections.push((name, text));
    }
    let mut md = String::from(
        "# Command-line reference\n\n\
         `crossym --help` and the `--help` of every command, as the binary prints them.\n\n\
         Generated from the command-line definitions (clap) in `src/cli/`: do not edit by \
         hand. After changing a command, regenerate with\n\n\
         ```sh\n\
         CROSSYM_BLESS=1 cargo test --test integration reference::cli_md\n\
         ```\n\n\
         (`cargo test` fails while this file differs from the binary's help.) Exit codes of \
         every command: 0 success, 1 a check failed (named in each command's description), \
         2 a usage or input error (bad arguments, config, URDF, data).\n\n",
    );
    for (name, _) in &sections {
        let anchor = name.replace(' ', "-");
        md.push_str(&format!("- [`{name}`](#{anchor})\n"));
    }
    for (name, text) in &sections {
        md.push_str(&format!("\n## `{name}`\n\n```text\n{}```\n", text));
    }
    md
}

#[test]
fn cli_md() {
    let md = render_cli_md();
    let path = common::path("docs/reference/cli.md");
    if std::env::var_os("CROSSYM_BLESS").is_some() {
        std::fs::write(&path, &md).expect("write cli.md");
        return;
    }
    let old = std::fs::read_to_string(&path).unwrap_or_default();
    if old != md {
        let first = old
            .lines()
            .zip(md.lines())
            .position(|(a, b)| a != b)
            .unwrap_or(old.lines().count().min(md.lines().count()));
        panic!(
            "docs/reference/cli.md differs from the binary's help from line {}:\n  file:   {:?}\n  \
             binary: {:?}\nregenerate it: CROSSYM_BLESS=1 cargo test --test integration \
             reference::cli_md",
            first + 1,
            old.lines().nth(first).unwrap_or("(end)"),
            md.lines().nth(first).unwrap_or("(end)")
        );
    }
}

/// `git ARGS…` in the source tree; `None` when git fails (not a checkout, no git).
fn git(args: &[&str]) -> Option<String> {
    let out = std::process::Command::new("git")
        .args(args)
        .current_dir(common::root())
        .output()
        .ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

#[test]
fn version() {
    let out = common::run_ok(&mut common::crossym(["--version"]));
    let line = out.trim_end();
    let prefix = format!("crossym {} (", env!("CARGO_PKG_VERSION"));
    let hash = line
        .strip_prefix(&prefix)
        .and_then(|r| r.strip_suffix(')'))
        .unwrap_or_else(|| panic!("`crossym --version` printed {line:?}, want `{prefix}<hash>)`"));
    // What build.rs gave this build (the test is compiled with the binary).
    assert_eq!(hash, env!("CROSSYM_GIT_HASH"));
    let top = git(&["rev-parse", "--show-toplevel"]).map(std::path::PathBuf::from);
    let checkout = top.is_some_and(|t| t.canonicalize().ok() == common::root().canonicalize().ok());
    if !checkout {
        assert!(
            hash == "unknown" || std::env::var_os("CROSSYM_GIT_HASH").is_some(),
            "not a git checkout: the hash should be `unknown`, got {hash}"
        );
        return;
    }
    let head = git(&["rev-parse", "--short", "HEAD"]).expect("HEAD");
    if hash == head {
        return;
    }
    // Another commit may have landed between the build and this run: then HEAD is newer than
    // the binary, and the binary's commit one of its ancestors.
    let committed: u64 = git(&["log", "-1", "--format=%ct", "HEAD"])
        .and_then(|t| t.parse().ok())
        .expect("HEAD's commit time");
    let built = std::fs::metadata(env!("CARGO_BIN_EXE_crossym"))
        .and_then(|m| m.modified())
        .expect("binary's mtime")
        .duration_since(std::time::UNIX_EPOCH)
        .expect("after 1970")
        .as_secs();
    assert!(
        committed >= built && git(&["merge-base", "--is-ancestor", hash, "HEAD"]).is_some(),
        "`crossym --version` says commit {hash}, HEAD is {head} (committed before the binary \
         was built: build.rs did not rerun when HEAD moved)"
    );
}

#[test]
fn messages_md() {
    let md = reference("messages.md");
    let dir = common::path("msgs/msg");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .expect("msgs/msg")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "msg"))
        .collect();
    files.sort();
    assert!(!files.is_empty());
    for f in &files {
        let name = f.file_stem().expect("stem").to_string_lossy();
        let heading = format!("## `crossym_msgs/msg/{name}`");
        let section: Vec<&str> = md
            .lines()
            .skip_while(|l| *l != heading)
            .skip(1)
            .take_while(|l| !l.starts_with("## "))
            .collect();
        assert!(
            !section.is_empty(),
            "docs/reference/messages.md has no section `{heading}` for {}",
            f.display()
        );
        let def = crossym::msgdef::MsgDef::parse(&std::fs::read_to_string(f).expect("read"))
            .unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        let mut missing = Vec::new();
        for field in &def.fields {
            let row = format!("| `{}` | `{}` |", field.name, field.ty);
            if !section.iter().any(|l| l.starts_with(&row)) {
                missing.push(row);
            }
        }
        for constant in &def.constants {
            let row = format!("| `{}` | {} |", constant.name, constant.value);
            if !section.iter().any(|l| l.starts_with(&row)) {
                missing.push(row);
            }
        }
        assert!(
            missing.is_empty(),
            "docs/reference/messages.md, section {heading}: no row for {} of {}:\n{}",
            if missing.len() == 1 {
                "this entry"
            } else {
                "these entries"
            },
            f.display(),
            missing.join("\n")
        );
    }
}
