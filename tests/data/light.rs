//! The renderer's baselines (issue 40 part 1, math.md §11) under real maps: every one of
//! `mc-light`, `mc-bsdf`, `mis` (power, balance, compensation, Sobol) has its mean over many
//! trials within 4 standard errors of the certified texel-sum truth, for a Lambertian and a
//! tilted Phong surface under Pisa (1024×512) and a Lambertian one facing Park's sun; so has every
//! variant of `bq-pss` at N = 128 (its ratio-type weights are unbiased only as the set grows).

use crate::light_baselines::{check_unbiased, check_unbiased_with, pss_variants};
use crate::{Data, Test};
use workbench::experiment::plan::resolve_integrand;
use workbench::experiment::spec::IntegrandSpec;

pub const TESTS: &[Test] = &[(
    "baselines_are_unbiased_under_pisa_and_park",
    baselines_are_unbiased_under_pisa_and_park,
)];

fn baselines_are_unbiased_under_pisa_and_park(_: &Data) {
    let cases = [
        serde_json::json!({"type": "envmap", "env": "pisa", "normal": [0.3, 0.8, -0.5]}),
        serde_json::json!({"type": "envmap", "env": "pisa", "normal": [0.0, 0.6, 0.8],
                           "brdf": {"phong": 20, "axis": [0.3, 0.0, 0.954]}}),
        serde_json::json!({"type": "envmap", "env": "park", "normal": [-0.579, 0.18, 0.795]}),
    ];
    for spec in cases {
        let f = resolve_integrand(&serde_json::from_value::<IntegrandSpec>(spec).unwrap()).unwrap();
        check_unbiased(&f, 16, 1000, 41);
        check_unbiased_with(&pss_variants(), &f, 128, 400, 41);
    }
}
