//! The standard-normal quantile `phi^{-1}(beta)` of the tightening, eq. (20).
//!
//! Wichura's algorithm AS241 (`PPND16`, Applied Statistics 37(3), 1988): rational approximations
//! on three ranges of `p`, accurate to about 1e-16 relative.
//!
//! ```
//! use safe_cddp::quantile::normal_quantile;
//! assert_eq!(normal_quantile(0.5), Some(0.0));
//! assert!((normal_quantile(0.99).unwrap() - 2.326347874040841).abs() < 1e-14);
//! assert_eq!(normal_quantile(1.5), None);
//! ```

// The published 20-digit coefficients are kept as printed (the compiler rounds them to f64).
#![allow(clippy::excessive_precision)]

const SPLIT1: f64 = 0.425;
const SPLIT2: f64 = 5.0;
const CONST1: f64 = 0.180625;
const CONST2: f64 = 1.6;

// Coefficients of AS241 (numerators a, c, e; denominators b, d, f), lowest degree first.
const A: [f64; 8] = [
    3.387_132_872_796_366_608,
    1.331_416_678_917_843_774_5e2,
    1.971_590_950_306_551_442_7e3,
    1.373_169_376_550_946_112_5e4,
    4.592_195_393_154_987_145_7e4,
    6.726_577_092_700_870_085_3e4,
    3.343_057_558_358_812_810_5e4,
    2.509_080_928_730_122_672_7e3,
];
const B: [f64; 8] = [
    1.0,
    4.231_333_070_160_091_125_2e1,
    6.871_870_074_920_579_083_0e2,
    5.394_196_021_424_751_107_7e3,
    2.121_379_430_158_659_586_7e4,
    3.930_789_580_009_271_061_0e4,
    2.872_908_573_572_194_267_4e4,
    5.226_495_278_852_854_561_0e3,
];
const C: [f64; 8] = [
    1.423_437_110_749_683_577_34,
    4.630_337_846_156_545_295_90,
    5.769_497_221_460_691_405_50,
    3.647_848_324_763_204_605_04,
    1.270_458_252_452_368_382_58,
    2.417_807_251_774_506_117_70e-1,
    2.272_384_498_926_918_458_33e-2,
    7.745_450_142_783_414_076_40e-4,
];
const D: [f64; 8] = [
    1.0,
    2.053_191_626_637_758_821_87,
    1.676_384_830_183_803_849_40,
    6.897_673_349_851_000_045_50e-1,
    1.481_039_764_274_800_745_90e-1,
    1.519_866_656_361_645_719_66e-2,
    5.475_938_084_995_344_946_00e-4,
    1.050_750_071_644_416_843_24e-9,
];
const E: [f64; 8] = [
    6.657_904_643_501_103_777_20,
    5.463_784_911_164_114_369_90,
    1.784_826_539_917_291_335_80,
    2.965_605_718_285_048_912_30e-1,
    2.653_218_952_657_612_309_30e-2,
    1.242_660_947_388_078_438_60e-3,
    2.711_555_568_743_487_578_15e-5,
    2.010_334_399_292_288_132_65e-7,
];
const F: [f64; 8] = [
    1.0,
    5.998_322_065_558_879_376_90e-1,
    1.369_298_809_227_358_053_10e-1,
    1.487_536_129_085_061_485_25e-2,
    7.868_691_311_456_132_591_00e-4,
    1.846_318_317_510_054_681_80e-5,
    1.421_511_758_316_445_888_70e-7,
    2.044_263_103_389_939_785_64e-15,
];

fn poly(c: &[f64; 8], x: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &ci| acc * x + ci)
}

/// `phi^{-1}(p)`, the quantile of the standard normal distribution: `None` unless `0 < p < 1`
/// (NaN included). `normal_quantile(0.5) == Some(0.0)` exactly, so `beta = 0.5` is plain CDDP.
pub fn normal_quantile(p: f64) -> Option<f64> {
    if !(p > 0.0 && p < 1.0) {
        return None;
    }
    let q = p - 0.5;
    if q.abs() <= SPLIT1 {
        let r = CONST1 - q * q;
        return Some(q * poly(&A, r) / poly(&B, r));
    }
    let r = if q < 0.0 { p } else { 1.0 - p };
    let r = (-r.ln()).sqrt();
    let z = if r <= SPLIT2 {
        let r = r - CONST2;
        poly(&C, r) / poly(&D, r)
    } else {
        let r = r - SPLIT2;
        poly(&E, r) / poly(&F, r)
    };
    Some(if q < 0.0 { -z } else { z })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantile_matches_tables() {
        // The four beta of Table I, and two more from standard tables.
        let cases = [
            (0.5, 0.0),
            (0.9, 1.2815515655446004),
            (0.95, 1.6448536269514722),
            (0.99, 2.3263478740408408),
            (0.975, 1.959963984540054),
            (0.999, 3.090232306167813),
        ];
        for (p, z) in cases {
            let got = normal_quantile(p).unwrap();
            assert!((got - z).abs() < 1e-13 * (1.0 + z.abs()), "p = {p}: {got} vs {z}");
            let mirrored = normal_quantile(1.0 - p).unwrap();
            assert!((mirrored + z).abs() < 1e-12, "p = {}: {mirrored} vs {}", 1.0 - p, -z);
        }
        // Deep tail (third range of AS241): phi^{-1}(1e-12) = -7.034483825...
        let z = normal_quantile(1e-12).unwrap();
        assert!((z + 7.034483825).abs() < 1e-8, "{z}");
    }

    #[test]
    fn quantile_rejects_outside_unit_interval() {
        for p in [0.0, 1.0, -0.1, 1.1, f64::NAN, f64::INFINITY] {
            assert_eq!(normal_quantile(p), None, "p = {p}");
        }
    }

    #[test]
    fn quantile_is_increasing() {
        let mut last = f64::NEG_INFINITY;
        for i in 1..1000 {
            let z = normal_quantile(i as f64 / 1000.0).unwrap();
            assert!(z > last);
            last = z;
        }
    }
}
