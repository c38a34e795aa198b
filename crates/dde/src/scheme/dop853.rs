//! Dormand–Prince 8(5,3), the DOP853 code of Hairer and Wanner (Hairer–Nørsett–Wanner,
//! *Solving ODEs I*, §II.10, with the coefficients of the code's published source): twelve
//! stages of order 8 with FSAL (twelve new right-hand sides per step), an error estimate
//! that blends the embedded 5th- and 3rd-order differences, and a continuous extension of
//! order 7 that costs three more stages — computed only for the steps that need it.

// the coefficients are kept digit for digit as published, so that they can be checked
// against the source; f64 rounds them
#![allow(clippy::excessive_precision)]

use nalgebra::SVector;

use super::{Scheme, hermite_part};
use crate::dense::Segment;
use crate::step::{Plan, Rhs, Tolerances};

type SV<const N: usize> = SVector<f64, N>;

// nodes
const C2: f64 = 0.526001519587677318785587544488e-01;
const C3: f64 = 0.789002279381515978178381316732e-01;
const C4: f64 = 0.118350341907227396726757197510e+00;
const C5: f64 = 0.281649658092772603273242802490e+00;
const C6: f64 = 0.333333333333333333333333333333e+00;
const C7: f64 = 0.25e+00;
const C8: f64 = 0.307692307692307692307692307692e+00;
const C9: f64 = 0.651282051282051282051282051282e+00;
const C10: f64 = 0.6e+00;
const C11: f64 = 0.857142857142857142857142857142e+00;
// (c12 = 1: the step's end)
const C14: f64 = 0.1e+00;
const C15: f64 = 0.2e+00;
const C16: f64 = 0.777777777777777777777777777778e+00;

// 8th-order weights (the nonzero ones)
const B1: f64 = 5.42937341165687622380535766363e-2;
const B6: f64 = 4.45031289275240888144113950566e0;
const B7: f64 = 1.89151789931450038304281599044e0;
const B8: f64 = -5.8012039600105847814672114227e0;
const B9: f64 = 3.1116436695781989440891606237e-1;
const B10: f64 = -1.52160949662516078556178806805e-1;
const B11: f64 = 2.01365400804030348374776537501e-1;
const B12: f64 = 4.47106157277725905176885569043e-2;

// 3rd-order weights of the second error estimate
const BHH1: f64 = 0.244094488188976377952755905512e+00;
const BHH2: f64 = 0.733846688281611857341361741547e+00;
const BHH3: f64 = 0.220588235294117647058823529412e-01;

// 8th minus 5th order weights (the first error estimate)
const ER1: f64 = 0.1312004499419488073250102996e-01;
const ER6: f64 = -0.1225156446376204440720569753e+01;
const ER7: f64 = -0.4957589496572501915214079952e+00;
const ER8: f64 = 0.1664377182454986536961530415e+01;
const ER9: f64 = -0.3503288487499736816886487290e+00;
const ER10: f64 = 0.3341791187130174790297318841e+00;
const ER11: f64 = 0.8192320648511571246570742613e-01;
const ER12: f64 = -0.2235530786388629525884427845e-01;

// the Runge–Kutta matrix (nonzero entries)
const A21: f64 = 5.26001519587677318785587544488e-2;
const A31: f64 = 1.97250569845378994544595329183e-2;
const A32: f64 = 5.91751709536136983633785987549e-2;
const A41: f64 = 2.95875854768068491816892993775e-2;
const A43: f64 = 8.87627564304205475450678981324e-2;
const A51: f64 = 2.41365134159266685502369798665e-1;
const A53: f64 = -8.84549479328286085344864962717e-1;
const A54: f64 = 9.24834003261792003115737966543e-1;
const A61: f64 = 3.7037037037037037037037037037e-2;
const A64: f64 = 1.70828608729473871279604482173e-1;
const A65: f64 = 1.25467687566822425016691814123e-1;
const A71: f64 = 3.7109375e-2;
const A74: f64 = 1.70252211019544039314978060272e-1;
const A75: f64 = 6.02165389804559606850219397283e-2;
const A76: f64 = -1.7578125e-2;
const A81: f64 = 3.70920001185047927108779319836e-2;
const A84: f64 = 1.70383925712239993810214054705e-1;
const A85: f64 = 1.07262030446373284651809199168e-1;
const A86: f64 = -1.53194377486244017527936158236e-2;
const A87: f64 = 8.27378916381402288758473766002e-3;
const A91: f64 = 6.24110958716075717114429577812e-1;
const A94: f64 = -3.36089262944694129406857109825e0;
const A95: f64 = -8.68219346841726006818189891453e-1;
const A96: f64 = 2.75920996994467083049415600797e1;
const A97: f64 = 2.01540675504778934086186788979e1;
const A98: f64 = -4.34898841810699588477366255144e1;
const A101: f64 = 4.77662536438264365890433908527e-1;
const A104: f64 = -2.48811461997166764192642586468e0;
const A105: f64 = -5.90290826836842996371446475743e-1;
const A106: f64 = 2.12300514481811942347288949897e1;
const A107: f64 = 1.52792336328824235832596922938e1;
const A108: f64 = -3.32882109689848629194453265587e1;
const A109: f64 = -2.03312017085086261358222928593e-2;
const A111: f64 = -9.3714243008598732571704021658e-1;
const A114: f64 = 5.18637242884406370830023853209e0;
const A115: f64 = 1.09143734899672957818500254654e0;
const A116: f64 = -8.14978701074692612513997267357e0;
const A117: f64 = -1.85200656599969598641566180701e1;
const A118: f64 = 2.27394870993505042818970056734e1;
const A119: f64 = 2.49360555267965238987089396762e0;
const A1110: f64 = -3.0467644718982195003823669022e0;
const A121: f64 = 2.27331014751653820792359768449e0;
const A124: f64 = -1.05344954667372501984066689879e1;
const A125: f64 = -2.00087205822486249909675718444e0;
const A126: f64 = -1.79589318631187989172765950534e1;
const A127: f64 = 2.79488845294199600508499808837e1;
const A128: f64 = -2.85899827713502369474065508674e0;
const A129: f64 = -8.87285693353062954433549289258e0;
const A1210: f64 = 1.23605671757943030647266201528e1;
const A1211: f64 = 6.43392746015763530355970484046e-1;

// the three stages of the continuous extension (stage 13 is f at the step's end)
const A141: f64 = 5.61675022830479523392909219681e-2;
const A147: f64 = 2.53500210216624811088794765333e-1;
const A148: f64 = -2.46239037470802489917441475441e-1;
const A149: f64 = -1.24191423263816360469010140626e-1;
const A1410: f64 = 1.5329179827876569731206322685e-1;
const A1411: f64 = 8.20105229563468988491666602057e-3;
const A1412: f64 = 7.56789766054569976138603589584e-3;
const A1413: f64 = -8.298e-3;
const A151: f64 = 3.18346481635021405060768473261e-2;
const A156: f64 = 2.83009096723667755288322961402e-2;
const A157: f64 = 5.35419883074385676223797384372e-2;
const A158: f64 = -5.49237485713909884646569340306e-2;
const A1511: f64 = -1.08347328697249322858509316994e-4;
const A1512: f64 = 3.82571090835658412954920192323e-4;
const A1513: f64 = -3.40465008687404560802977114492e-4;
const A1514: f64 = 1.41312443674632500278074618366e-1;
const A161: f64 = -4.28896301583791923408573538692e-1;
const A166: f64 = -4.69762141536116384314449447206e0;
const A167: f64 = 7.68342119606259904184240953878e0;
const A168: f64 = 4.06898981839711007970213554331e0;
const A169: f64 = 3.56727187455281109270669543021e-1;
const A1613: f64 = -1.39902416515901462129418009734e-3;
const A1614: f64 = 2.9475147891527723389556272149e0;
const A1615: f64 = -9.15095847217987001081870187138e0;

// the four higher coefficients of the continuous extension, as combinations of the stages
// 1, 6–16 (rows: the 5th to 8th coefficient of the nested form in `Segment`)
const D4: [f64; 12] = [
    -0.84289382761090128651353491142e+01,
    0.56671495351937776962531783590e+00,
    -0.30689499459498916912797304727e+01,
    0.23846676565120698287728149680e+01,
    0.21170345824450282767155149946e+01,
    -0.87139158377797299206789907490e+00,
    0.22404374302607882758541771650e+01,
    0.63157877876946881815570249290e+00,
    -0.88990336451333310820698117400e-01,
    0.18148505520854727256656404962e+02,
    -0.91946323924783554000451984436e+01,
    -0.44360363875948939664310572000e+01,
];
const D5: [f64; 12] = [
    0.10427508642579134603413151009e+02,
    0.24228349177525818288430175319e+03,
    0.16520045171727028198505394887e+03,
    -0.37454675472269020279518312152e+03,
    -0.22113666853125306036270938578e+02,
    0.77334326684722638389603898808e+01,
    -0.30674084731089398182061213626e+02,
    -0.93321305264302278729567221706e+01,
    0.15697238121770843886131091075e+02,
    -0.31139403219565177677282850411e+02,
    -0.93529243588444783865713862664e+01,
    0.35816841486394083752465898540e+02,
];
const D6: [f64; 12] = [
    0.19985053242002433820987653617e+02,
    -0.38703730874935176555105901742e+03,
    -0.18917813819516756882830838328e+03,
    0.52780815920542364900561016686e+03,
    -0.11573902539959630126141871134e+02,
    0.68812326946963000169666922661e+01,
    -0.10006050966910838403183860980e+01,
    0.77771377980534432092869265740e+00,
    -0.27782057523535084065932004339e+01,
    -0.60196695231264120758267380846e+02,
    0.84320405506677161018159903784e+02,
    0.11992291136182789328035130030e+02,
];
const D7: [f64; 12] = [
    -0.25693933462703749003312586129e+02,
    -0.15418974869023643374053993627e+03,
    -0.23152937917604549567536039109e+03,
    0.35763911791061412378285349910e+03,
    0.93405324183624310003907691704e+02,
    -0.37458323136451633156875139351e+02,
    0.10409964950896230045147246184e+03,
    0.29840293426660503123344363579e+02,
    -0.43533456590011143754432175058e+02,
    0.96324553959188282948394950600e+02,
    -0.39177261675615439165231486172e+02,
    -0.14972683625798562581422125276e+03,
];

/// The stages `k[0] = k1 … k[11] = k12` of one DOP853 step, `f` at its end (stage 13) and
/// its result.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Dop853<const N: usize> {
    k: [SV<N>; 12],
    f_new: SV<N>,
    /// `(x_new − x) / h = Σ bᵢ kᵢ`
    increment: SV<N>,
    x_new: SV<N>,
}

impl<const N: usize> Scheme<N> for Dop853<N> {
    const ORDER: usize = 8;
    const EVALS: usize = 12;
    const EXPONENT: f64 = 1.0 / 8.0;
    const BETA_WEIGHT: f64 = 0.2;

    fn attempt<R: Rhs<N>>(rhs: &R, p: &Plan<N>) -> Self {
        let (x, k1, h) = (p.x, p.k1, p.h);
        let stage = |c: f64, sum: SV<N>| p.stage(rhs, c, sum);
        let k2 = stage(C2, k1 * A21);
        let k3 = stage(C3, k1 * A31 + k2 * A32);
        let k4 = stage(C4, k1 * A41 + k3 * A43);
        let k5 = stage(C5, k1 * A51 + k3 * A53 + k4 * A54);
        let k6 = stage(C6, k1 * A61 + k4 * A64 + k5 * A65);
        let k7 = stage(C7, k1 * A71 + k4 * A74 + k5 * A75 + k6 * A76);
        let k8 = stage(C8, k1 * A81 + k4 * A84 + k5 * A85 + k6 * A86 + k7 * A87);
        let k9 = stage(
            C9,
            k1 * A91 + k4 * A94 + k5 * A95 + k6 * A96 + k7 * A97 + k8 * A98,
        );
        let k10 = stage(
            C10,
            k1 * A101 + k4 * A104 + k5 * A105 + k6 * A106 + k7 * A107 + k8 * A108 + k9 * A109,
        );
        let k11 = stage(
            C11,
            k1 * A111
                + k4 * A114
                + k5 * A115
                + k6 * A116
                + k7 * A117
                + k8 * A118
                + k9 * A119
                + k10 * A1110,
        );
        // the 12th stage sits at the step's end (its left limit at a breakpoint)
        let sum12 = k1 * A121
            + k4 * A124
            + k5 * A125
            + k6 * A126
            + k7 * A127
            + k8 * A128
            + k9 * A129
            + k10 * A1210
            + k11 * A1211;
        let k12 = p.stage_at(rhs, p.t_end_stage(), sum12);
        let increment =
            k1 * B1 + k6 * B6 + k7 * B7 + k8 * B8 + k9 * B9 + k10 * B10 + k11 * B11 + k12 * B12;
        let x_new = x + increment * h;
        let mut f_new = SV::<N>::zeros();
        rhs.eval(p.t_last, &x_new, &mut f_new);
        Dop853 {
            k: [k1, k2, k3, k4, k5, k6, k7, k8, k9, k10, k11, k12],
            f_new,
            increment,
            x_new,
        }
    }

    fn x_new(&self) -> &SV<N> {
        &self.x_new
    }

    fn f_new(&self) -> &SV<N> {
        &self.f_new
    }

    /// Hairer's blend of the two estimates, `|h| · E₅² / √(N (E₅² + 0.01 E₃²))` with `Eₖ²` the
    /// scaled square sums of the 8th-minus-5th and 8th-minus-3rd order differences: it
    /// behaves like the 5th-order estimate for small errors and is kept from vanishing
    /// by accident by the 3rd-order one.
    fn error(&self, p: &Plan<N>, tol: Tolerances) -> f64 {
        let [k1, _, _, _, _, k6, k7, k8, k9, k10, k11, k12] = self.k;
        let e3 = self.increment - k1 * BHH1 - k9 * BHH2 - k12 * BHH3;
        let e5 = k1 * ER1
            + k6 * ER6
            + k7 * ER7
            + k8 * ER8
            + k9 * ER9
            + k10 * ER10
            + k11 * ER11
            + k12 * ER12;
        let err5 = tol.scaled_square_sum(&e5, &p.x, &self.x_new);
        let err3 = tol.scaled_square_sum(&e3, &p.x, &self.x_new);
        let mut deno = err5 + 0.01 * err3;
        if deno <= 0.0 {
            deno = 1.0;
        }
        p.h.abs() * err5 / (N as f64 * deno).sqrt()
    }

    /// The continuous extension of order 7: three more stages (at `0.1 h`, `0.2 h`, `7/9 h`)
    /// and the nested form of [`Segment`].
    fn dense<R: Rhs<N>>(&self, rhs: &R, p: &Plan<N>) -> (Segment<N>, usize) {
        let [k1, _, _, _, _, k6, k7, k8, k9, k10, k11, k12] = self.k;
        let (t, x, h) = (p.t, p.x, p.h);
        let k13 = self.f_new;
        let stage = |c: f64, sum: SV<N>| p.stage(rhs, c, sum);
        let k14 = stage(
            C14,
            k1 * A141
                + k7 * A147
                + k8 * A148
                + k9 * A149
                + k10 * A1410
                + k11 * A1411
                + k12 * A1412
                + k13 * A1413,
        );
        let k15 = stage(
            C15,
            k1 * A151
                + k6 * A156
                + k7 * A157
                + k8 * A158
                + k11 * A1511
                + k12 * A1512
                + k13 * A1513
                + k14 * A1514,
        );
        let k16 = stage(
            C16,
            k1 * A161
                + k6 * A166
                + k7 * A167
                + k8 * A168
                + k9 * A169
                + k13 * A1613
                + k14 * A1614
                + k15 * A1615,
        );
        let ks = [k1, k6, k7, k8, k9, k10, k11, k12, k13, k14, k15, k16];
        let combine = |d: &[f64; 12]| {
            let mut s = SV::<N>::zeros();
            for (k, &di) in ks.iter().zip(d) {
                s += k * di;
            }
            s * h
        };
        let [r0, r1, r2, r3] = hermite_part(&x, &self.x_new, &k1, &k13, h);
        let r = [
            r0,
            r1,
            r2,
            r3,
            combine(&D4),
            combine(&D5),
            combine(&D6),
            combine(&D7),
        ];
        (Segment::order7(t, p.t_new, h, r), 3)
    }
}

#[cfg(test)]
mod tests;
