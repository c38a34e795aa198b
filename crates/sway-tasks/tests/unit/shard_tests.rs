use sway::ranging::SpeedSpec;
use sway_studies::sweep::SweepConfig;
use sway_tasks::shard::*;
use trailer_model::VehicleParams;

#[test]
fn slices_cover_every_point_once_for_1_to_17_shards() {
    // reference: the definition — each point 0..total in exactly one slice, slices in
    // order, sizes within one of each other; totals include grid shapes 1, primes,
    // fewer points than shards, and products of axis sizes
    let totals = [0usize, 1, 2, 3, 7, 16, 17, 64 * 16, 5 * 7 * 3, 1_000_003];
    for &total in &totals {
        for n in 1..=17 {
            let mut seen = vec![0u8; total.min(2_000_000)];
            let mut next = 0;
            let (mut lo, mut hi) = (usize::MAX, 0);
            for k in 1..=n {
                let r = ShardSpec::new(k, n).expect("valid").range(total);
                assert_eq!(r.start, next, "contiguous, in order");
                next = r.end;
                lo = lo.min(r.len());
                hi = hi.max(r.len());
                for i in r {
                    seen[i] += 1;
                }
            }
            assert_eq!(next, total);
            assert!(seen.iter().all(|&c| c == 1), "total {total}, N {n}");
            assert!(hi - lo <= 1, "balanced: {lo}..{hi}");
        }
    }
}

#[test]
fn spec_parses_k_of_n_and_refuses_nonsense() {
    let s: ShardSpec = "3/4".parse().expect("parses");
    assert_eq!((s.shard, s.shards), (3, 4));
    assert_eq!(s.file_name(), "shard-3-of-4.json");
    assert_eq!(
        ShardSpec::new(7, 12).expect("valid").file_name(),
        "shard-07-of-12.json"
    );
    for bad in ["0/4", "5/4", "1/0", "x/4", "4", "1/100001", "-1/3"] {
        let e = bad.parse::<ShardSpec>().expect_err(bad).to_string();
        assert!(e.contains(bad) && e.contains("K/N"), "{e}");
    }
}

#[test]
fn the_hash_is_fnv1a_and_sees_every_input() {
    // reference: FNV-1a 64 test vectors (the published offset basis and "a")
    assert_eq!(fnv1a64(b""), 0xcbf2_9ce4_8422_2325);
    assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
    let cfg: SweepConfig<SpeedSpec> = toml::from_str(
        "name = \"h\"\n[[axes]]\nparameter = \"speed_mps\"\nmin = 30.0\nmax = 34.0\npoints = 3\n[base]\nspeed = { kind = \"constant\", speed_mps = 33.0 }\ncontroller = { kind = \"none\" }\ninitial = { kind = \"state\", theta0_deg = 5.0 }\n",
    )
    .expect("parses");
    let v = VehicleParams::default();
    let hash = |c: &SweepConfig<SpeedSpec>, v: &VehicleParams, fleet: &[VehicleParams]| {
        config_hash::<SweepPoints>(c, v, fleet).expect("hashes")
    };
    let h = hash(&cfg, &v, &[]);
    assert_eq!(h, hash(&cfg, &v, &[]));
    let mut c2 = cfg.clone();
    c2.axes[0].points = Some(4);
    assert_ne!(h, hash(&c2, &v, &[]));
    let mut v2 = v;
    v2.trailer.mass *= 1.0 + f64::EPSILON;
    assert_ne!(h, hash(&cfg, &v2, &[]));
    assert_ne!(h, hash(&cfg, &v, &[v]));
}
