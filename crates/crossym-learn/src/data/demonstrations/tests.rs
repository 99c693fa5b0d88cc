//! Kinds inferred from keys, foreign keys refused, picks resolved.

use super::load::named;
use super::*;
use crate::data::clean::CleanConfig;
use crossym_policy::JointTrajectory;

fn parse(text: &str) -> Result<DemonstrationsConfig, String> {
    let d: DemonstrationsConfig = toml::from_str(text).map_err(|e| e.to_string())?;
    d.validate().map_err(|e| e.to_string())?;
    Ok(d)
}

#[test]
fn kinds_are_inferred_from_keys_and_foreign_keys_are_refused() {
    let d = parse(
        "dt = 0.01\ntrain = [\"a\", 2]\n\
         [[sources]]\nname = \"a\"\nbag = \"rec/a\"\n\
         [[sources]]\nname = \"b\"\ncsv = \"b.csv\"\n\
         [[sources]]\nname = \"c\"\narms = [{ chain = \"left\", rest = [0.0], letter = \"x.mat\" }]\n\
         [[sources]]\nname = \"d\"\narms = [{ chain = \"left\", rest = [0.0], reach = [{ goal = [1.0, 0.0], duration_s = 1.0 }] }]\n",
    )
    .unwrap();
    let kinds: Vec<_> = d
        .sources
        .iter()
        .map(|s| s.resolved_kind().unwrap())
        .collect();
    use SourceKind::*;
    assert_eq!(kinds, [Bag, Csv, Lasa, Reach]);
    assert_eq!(d.train, [Pick::Name("a".into()), Pick::Number(2)]);
    for (text, needle) in [
        (
            "[[sources]]\nname = \"a\"\nbag = \"x\"\nhalf_range = 1.0\n",
            "`half_range` does not apply",
        ),
        (
            "[[sources]]\nname = \"a\"\ncsv = \"x\"\ntopic = \"/j\"\n",
            "`topic` does not apply",
        ),
        ("[[sources]]\nname = \"a\"\nkind = \"bag\"\n", "needs `bag`"),
        ("[[sources]]\nname = \"a\"\n", "give `bag`, `csv`"),
        ("[[sources]]\nname = \"a#1\"\nbag = \"x\"\n", "with `#`"),
        (
            "[[sources]]\nname = \"a\"\nbag = \"x\"\n[[sources]]\nname = \"a\"\nbag = \"y\"\n",
            "twice",
        ),
        (
            "train = [\"z\"]\n[[sources]]\nname = \"a\"\nbag = \"x\"\n",
            "`z` is not a source",
        ),
        (
            "train = [0]\n[[sources]]\nname = \"a\"\nbag = \"x\"\n",
            "start at 1",
        ),
    ] {
        let e = parse(&format!("dt = 0.01\n{text}")).unwrap_err();
        assert!(e.contains(needle), "{text}: {e}");
    }
}

fn traj(v: f64) -> JointTrajectory {
    JointTrajectory {
        demo: 0,
        n: 1,
        m: 1,
        dt: 0.01,
        q: vec![v; 3],
        qdot: vec![0.0; 3],
        x: vec![v; 3],
    }
}

fn source(name: &str, k: usize) -> SourceDemos {
    SourceDemos {
        name: name.into(),
        kind: SourceKind::Bag,
        demos: named(name, (0..k).map(|i| traj(i as f64)).collect()),
        detail: SourceDetail::Tracked {
            max_tracking_error: 0.0,
        },
    }
}

#[test]
fn picks_resolve_by_number_demonstration_name_and_source_name() {
    let cfg = |train: Vec<Pick>, test: Vec<Pick>| DemonstrationsConfig {
        dt: 0.01,
        train,
        test,
        cleaning: CleanConfig::default(),
        sources: Vec::new(),
    };
    let sources = || vec![source("a", 1), source("b", 3), source("c", 1)];
    let name = |s: &str| Pick::Name(s.into());
    let d = Demonstrations::from_sources(
        &cfg(
            vec![name("b"), name("a"), Pick::Number(2)],
            vec![name("b#3"), Pick::Number(5)],
        ),
        sources(),
    )
    .unwrap();
    assert_eq!(d.names, ["a", "b#1", "b#2", "b#3", "c"]);
    assert_eq!(
        d.demos.iter().map(|t| t.demo).collect::<Vec<_>>(),
        [1, 2, 3, 4, 5]
    );
    // `b` = its three demonstrations; `a`; 2 again is not repeated.
    assert_eq!(d.train, [2, 3, 4, 1]);
    assert_eq!(d.test, [4, 5]);
    assert_eq!(d.name(4), "b#3");
    assert_eq!(d.name(9), "–");
    for bad in [Pick::Number(6), name("b#4"), name("d")] {
        let e = Demonstrations::from_sources(&cfg(vec![bad.clone()], vec![]), sources())
            .unwrap_err()
            .to_string();
        assert!(e.contains(&bad.to_string().replace('`', "")), "{bad}: {e}");
    }
}
