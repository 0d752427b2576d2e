//! The numbers of Diachin, Knupp, Munson and Shontz, "A comparison of two
//! optimization methods for mesh quality improvement", section 4, quoted so
//! the study's tables can stand next to them. Times are seconds on the
//! paper's 1.6 GHz workstation (2005): compare shapes and ratios, not
//! seconds.

/// Table 1: name, |V|, |E|, inverse mean ratio avg, median, sigma_n, max,
/// volume avg, median, sigma_n.
pub const TABLE1: [(&str, usize, usize, [f64; 7]); 6] = [
    ("Duct20", 1067, 4104, [1.208, 1.176, 0.115, 2.2, 1167.0, 1176.0, 0.285]),
    ("Duct15", 2139, 9000, [1.210, 1.179, 0.116, 2.1, 532.0, 519.0, 0.304]),
    ("Duct12", 4199, 19222, [1.209, 1.182, 0.111, 2.1, 249.0, 237.0, 0.327]),
    ("Duct10", 7297, 35045, [1.120, 1.170, 0.106, 2.2, 136.0, 128.0, 0.310]),
    ("Duct8", 13193, 65574, [1.19, 1.162, 0.105, 2.4, 73.0, 68.0, 0.320]),
    ("DuctBig", 177887, 965759, [1.18, 1.160, 0.109, 4.9, 4.1, 2.91, 0.587]),
];

/// Iterations, T100 and T50 of Newton then BCD (Tables 2, 4, 5 and 7).
pub type Times = (usize, f64, f64, usize, f64, f64);

/// Table 2, by the rows of Table 1.
pub const TABLE2: [Times; 6] = [
    (4, 0.05, 0.015, 33, 0.32, 0.005),
    (5, 0.13, 0.025, 46, 1.1, 0.011),
    (5, 0.34, 0.056, 74, 4.2, 0.037),
    (5, 0.69, 0.106, 105, 11.6, 0.081),
    (5, 1.4, 0.213, 146, 31.0, 0.152),
    (8, 44.3, 4.52, 548, 1738.0, 2.47),
];

/// Table 3: name, |V|, |E|, inverse mean ratio avg, median, sigma_n, max,
/// volume avg, median, sigma_n, max:min.
pub const TABLE3: [(&str, usize, usize, [f64; 8]); 4] = [
    (
        "Hetero1",
        10318,
        54132,
        [1.271, 1.171, 0.330, 17.1, 1.84e-5, 1.10e-5, 1.11, 5.5e3],
    ),
    (
        "Hetero2",
        9883,
        56184,
        [1.274, 1.172, 0.371, 30.2, 1.77e-5, 6.04e-6, 1.46, 2.3e5],
    ),
    (
        "Hetero3",
        10926,
        58610,
        [1.275, 1.173, 0.413, 58.6, 1.70e-5, 3.89e-7, 1.74, 7.2e7],
    ),
    (
        "Hetero4",
        11057,
        59985,
        [1.272, 1.173, 0.322, 16.1, 1.66e-5, 1.59e-6, 2.08, 4.2e6],
    ),
];

/// Table 4, by the rows of Table 3.
pub const TABLE4: [Times; 4] = [
    (16, 4.24, 0.386, 674, 122.0, 0.128),
    (13, 3.53, 0.345, 708, 132.0, 0.192),
    (21, 5.41, 0.432, 505, 93.0, 0.207),
    (15, 4.22, 0.641, 554, 109.0, 0.168),
];

/// The paper's perturbations of the optimised DuctBig (section 4.3), in its
/// absolute units; its mean edge length is 3.6.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PaperPerturbation {
    /// `x + alpha r`, r uniform in [0, 1]^3.
    Random { alpha: f64 },
    /// `x + alpha sin(omega x)` per coordinate.
    Oscillatory { alpha: f64, omega: f64 },
    /// `x + alpha [1, 0, 0]`.
    Right { alpha: f64 },
    /// `x + alpha [1, 1, 0]`.
    NorthEast { alpha: f64 },
}

/// The paper's mean edge length of DuctBig, its unit for the perturbations.
pub const EDGE: f64 = 3.6;

/// Table 5: perturbation and Newton/BCD iterations, T100, T50.
pub const TABLE5: [(PaperPerturbation, Times); 16] = {
    use PaperPerturbation::*;
    [
        (Random { alpha: 0.001 }, (3, 11.8, 7.46, 325, 104.0, 3.90)),
        (Random { alpha: 0.005 }, (4, 23.6, 7.53, 387, 324.0, 3.84)),
        (Random { alpha: 0.01 }, (4, 23.3, 7.53, 414, 427.0, 3.89)),
        (Random { alpha: 0.05 }, (4, 22.6, 7.42, 476, 664.0, 3.84)),
        (
            Oscillatory {
                alpha: 0.01,
                omega: 0.1,
            },
            (4, 22.7, 7.56, 279, 244.0, 5.59),
        ),
        (
            Oscillatory {
                alpha: 0.05,
                omega: 0.1,
            },
            (4, 21.2, 7.50, 338, 368.0, 5.63),
        ),
        (
            Oscillatory {
                alpha: 0.01,
                omega: 0.05,
            },
            (4, 24.1, 7.95, 374, 353.0, 4.77),
        ),
        (
            Oscillatory {
                alpha: 0.05,
                omega: 0.05,
            },
            (5, 22.4, 8.02, 435, 550.0, 4.74),
        ),
        (
            Oscillatory {
                alpha: 0.01,
                omega: 0.01,
            },
            (4, 25.4, 8.29, 415, 425.0, 4.75),
        ),
        (
            Oscillatory {
                alpha: 0.05,
                omega: 0.01,
            },
            (4, 24.7, 8.32, 477, 655.0, 4.76),
        ),
        (Right { alpha: 0.1 }, (5, 30.6, 8.31, 502, 789.0, 4.72)),
        (Right { alpha: 0.2 }, (7, 36.7, 8.35, 528, 904.0, 4.79)),
        (Right { alpha: 0.3 }, (10, 47.2, 7.42, 545, 956.0, 8.24)),
        (NorthEast { alpha: 0.1 }, (5, 31.1, 8.32, 496, 800.0, 4.64)),
        (NorthEast { alpha: 0.2 }, (7, 38.1, 8.66, 522, 905.0, 4.66)),
        (NorthEast { alpha: 0.3 }, (11, 59.4, 13.5, 539, 962.0, 7.99)),
    ]
};

/// Figure 6's bottom rows perturb random subsets of the vertices.
pub const SUBSET_FRACTIONS: [f64; 3] = [0.01, 0.10, 0.25];

/// Table 6: (2/sqrt 2) alpha (0 for the optimal mesh), inverse mean ratio
/// avg, sigma_n, max, volume max, sigma_n.
pub const TABLE6: [(f64, [f64; 5]); 8] = [
    (0.0, [1.135, 0.093, 2.21, 30.2, 0.540]),
    (1.0, [1.155, 0.179, 2.72, 30.2, 0.546]),
    (2.5, [1.423, 2.25, 283.0, 30.2, 0.593]),
    (5.0, [2.062, 8.95, 1.59e4, 50.1, 0.755]),
    (7.5, [2.550, 58.1, 1.43e5, 52.7, 0.841]),
    (10.0, [2.508, 13.0, 2.02e4, 57.8, 0.865]),
    (12.5, [2.636, 69.9, 1.80e5, 65.5, 0.869]),
    (15.0, [2.468, 7.75, 9.47e3, 59.8, 0.869]),
];

/// Table 7, by the rows of Table 6 after the first.
pub const TABLE7: [Times; 7] = [
    (19, 100.0, 26.4, 575, 1106.0, 19.3),
    (61, 355.0, 28.4, 616, 1266.0, 35.0),
    (68, 388.0, 42.2, 632, 1313.0, 36.5),
    (83, 452.0, 52.7, 635, 1329.0, 34.1),
    (89, 503.0, 45.7, 635, 1347.0, 30.2),
    (115, 644.0, 59.4, 635, 1339.0, 34.0),
    (94, 525.0, 48.2, 633, 1328.0, 26.8),
];

/// What section 4.1 says of Figure 3 (the figure's points are not given).
pub const FIGURE3: &str = "at the crossover the mesh is nearly optimal (Duct15: 96%); BCD has \
     typically done fewer than five iterations; Newton's setup is over 25% of the time to the \
     crossover, BCD's typically under 10%; Newton takes roughly twice BCD's time to suboptimal \
     meshes above 20000 elements";

/// What section 4.2 says of Hetero1-4 at the crossover and of Figure 5.
pub const FIGURE5: &str = "the mesh is nearly 100% improved at the crossover; both methods spend \
     under 5% of their time in setup; many early Newton iterations meet negative curvature; BCD is \
     two to three times faster to most improvement levels";

/// What section 4.3 says of Figures 6 and 7.
pub const FIGURE6: &str = "random: BCD ahead up to 90% improvement; translational and oscillatory \
     (all vertices): crossover at 75% at best, about 63% for the larger oscillations; Newton's setup \
     about 30% of its time, BCD's about 10%; subsets (1%, 10%, 25%): Newton never ahead below 90%";
pub const FIGURE7: &str = "several crossovers; Newton ahead below about 40% improvement, BCD \
     between 40% and 90%, Newton above; Newton wins T100 by 11x (shift 1) to 2.5x (shift 15); \
     BCD 30-80% faster to T50 except at shift 2.5";
