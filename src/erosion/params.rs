//! Simulation parameters and named presets.

/// Parameters of `dh/dt = U - K A^m S^n + kappa * lap(h)` (the stream-power law with
/// uplift of Braun & Willett 2013 plus a linear hillslope-diffusion term) and of the
/// optional thermal (talus) erosion.
///
/// The uplift rate `U` is not a parameter: it is a per-cell field given to
/// [`Eroder::new`](super::Eroder::new) in m/yr (1 m/kyr = 0.001 m/yr; active mountain
/// belts 0.1..10 m/kyr).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErosionParams {
    /// Simulated time in years. Landscapes approach steady state after a few
    /// response times `~ L / (K A^m)` (typically 0.1..5 Myr for the presets).
    pub years: f64,
    /// Number of implicit time steps; `dt = years / steps`. The scheme is stable for any
    /// `dt`, but drainage reorganises only once per step, so use at least ~10.
    pub steps: u32,
    /// Erodibility `K` in m^(1-2m)/yr (slope is dimensionless, so `K A^m S^n` is in m/yr
    /// for any `n`). Higher `K` = faster incision, lower steady-state relief
    /// (`S = (U/K)^(1/n) A^(-m/n)`). Typical 1e-6 (hard rock) .. 1e-4 (weak sediment).
    pub erodibility: f64,
    /// Area exponent `m` (dimensionless). Only `m/n` (the channel concavity,
    /// 0.3..0.7 in nature, ~0.5 typical) and `n` matter for the profile shape.
    pub m: f64,
    /// Slope exponent `n` (dimensionless, 0.5..4; 1 is the common choice and the
    /// fastest: a closed-form update instead of Newton iterations).
    pub n: f64,
    /// Hillslope diffusivity `kappa` in m^2/yr (soil creep; 1e-3 .. 5e-2). Larger
    /// values round ridges and widen the spacing of valleys.
    pub diffusivity: f64,
    /// Talus (angle of repose) in degrees for thermal erosion, `None` = off. Slopes
    /// steeper than `tan(talus)` shed material to their lower neighbours.
    pub talus_deg: Option<f64>,
}

/// Names accepted by [`preset`].
pub const PRESETS: &[&str] = &[
    "young-mountains",
    "old-hills",
    "badlands",
    "mesas",
    "coastal-plain",
];

/// What a preset ([`PRESETS`]) makes, in a line for the user; `None` for an unknown name.
pub fn describe(name: &str) -> Option<&'static str> {
    Some(match name {
        "young-mountains" => {
            "Sharp V-shaped valleys and knife-edge ridges held near the talus angle."
        }
        "old-hills" => "Strong soil creep: rounded hilltops and broad valleys, lower relief.",
        "badlands" => "Weak material: dense, finely branched gullies.",
        "mesas" => {
            "Layered rock: soft beds stripped back to hard ones, whose edges stand as \
             escarpments round benches, mesas and buttes."
        }
        "coastal-plain" => {
            "Low land near the sea: broad, shallow valleys branching through gentle slopes, \
             rivers falling 1 m per km."
        }
        _ => return None,
    })
}

/// The slope of the drawn rivers (metres per metre, the design's `river_slope`) a preset asks
/// for, where its land needs one: a coastal plain's rivers fall about 1 m per km (the lower
/// Mississippi 0.1 m, coastal-plain streams 0.5-2 m), and the stream-power law's steady
/// slope there, `(U / K) A^(-m)`, is under 0.001 on every channel draining over 6 km^2: a
/// trunk held at the design's default 1% stood above the land around it, and the outlets on
/// the map's border, held at their nearest river's height, left basins as flat steps tens
/// of metres apart. `None`: the design's slope is the user's.
pub fn river_slope(name: &str) -> Option<f64> {
    match name {
        "coastal-plain" => Some(0.001),
        _ => None,
    }
}

/// Parameter presets for a ~10 km map with a few hundred metres of relief (cells of
/// ~10-20 m) and a caller-supplied uplift of up to ~0.5 m/kyr (tuned on the
/// `hillshade` example: 512^2 cells of 20 m, a low dome plus fractal noise, uplift
/// proportional to the initial height above base level). All use `n = 1`, which has a
/// closed-form implicit update and so is the fastest. 20 steps keep a 1024^2 run well
/// under 2 s; drainage reorganises once per step, so much fewer steps give straighter,
/// less branched valleys. Valley spacing is set by `kappa / K`, which for the sharp
/// presets is near the grid scale: on 10 m cells their valleys are finer than on 20 m
/// cells (raise `diffusivity` for a smoother, resolution-independent look).
///
/// * `young-mountains`: moderate `K` with little creep (`kappa/K` ~ 400 m, hillslopes
///   barely smoothed within a 20 m cell) and a 35 deg talus limit over 2 Myr: deep,
///   branching V-shaped valleys and sharp ridges, relief set by uplift vs incision.
/// * `old-hills`: twice the erodibility with ten times the creep (`kappa/K` = 2000 m)
///   over 3 Myr, `m = 0.45`: rounded convex hilltops, broad valleys, lower relief.
/// * `badlands`: weak material (`K` ~ 8x), almost no creep, 300 kyr, and a lower area
///   exponent `m = 0.4` so that small catchments incise too: dense, finely branched
///   gullies; steep 40 deg talus.
/// * `mesas`: plateau country cut into layered rock (the scene's beds, see
///   [`super::Strata`], which the preset's scene settings turn on): moderate `K`, little
///   creep (`kappa/K` = 250 m; less lets the soft beds channel at the cell scale on 50 m
///   cells, a speckle) and a 60 deg talus over 2 Myr, so that the soft beds are stripped back
///   to the hard beds' tops and the beds' edges stand as escarpments: benches, mesas, buttes
///   and stepped valley sides.
/// * `coastal-plain`: soft sediments (`K` ~ 2x) rising slowly (0.05 m/kyr, see the stage's
///   uplift) with strong creep (`kappa/K` = 2500 m) over 2 Myr, and no talus: relief
///   `~ U/K` small (77-121 m on 10-50 km maps at 512^2, 135-140 m at 10 km from 1024^2
///   on; the Olinda coastal lowland in `tests/data` spans 89 m over 10 km),
///   broad shallow valleys and wide low interfluves.
///   Its rivers fall gently ([`river_slope`]): held at the design's 1% they stood as raised
///   strips above land worn down to a few tens of metres.
///
/// Returns `None` for an unknown name.
pub fn preset(name: &str) -> Option<ErosionParams> {
    let p = match name {
        "young-mountains" => ErosionParams {
            years: 2.0e6,
            steps: 20,
            erodibility: 1.2e-5,
            m: 0.5,
            n: 1.0,
            diffusivity: 0.005,
            talus_deg: Some(35.0),
        },
        "old-hills" => ErosionParams {
            years: 3.0e6,
            steps: 20,
            erodibility: 2.5e-5,
            m: 0.45,
            n: 1.0,
            diffusivity: 0.05,
            talus_deg: None,
        },
        "badlands" => ErosionParams {
            years: 3.0e5,
            steps: 20,
            erodibility: 1.0e-4,
            m: 0.4,
            n: 1.0,
            diffusivity: 0.001,
            talus_deg: Some(40.0),
        },
        "mesas" => ErosionParams {
            years: 2.0e6,
            steps: 20,
            erodibility: 2.0e-5,
            m: 0.5,
            n: 1.0,
            diffusivity: 0.005,
            talus_deg: Some(60.0),
        },
        "coastal-plain" => ErosionParams {
            years: 2.0e6,
            steps: 20,
            erodibility: 2.0e-5,
            m: 0.5,
            n: 1.0,
            diffusivity: 0.05,
            talus_deg: None,
        },
        _ => return None,
    };
    Some(p)
}

impl ErosionParams {
    /// Checks every field; on failure returns `(field name, problem)`.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        fn require(
            ok: bool,
            field: &'static str,
            problem: String,
        ) -> Result<(), (&'static str, String)> {
            if ok { Ok(()) } else { Err((field, problem)) }
        }
        let p = self;
        require(
            p.years.is_finite() && p.years > 0.0,
            "years",
            format!("must be a finite number > 0, got {}", p.years),
        )?;
        require(
            (1..=1_000_000).contains(&p.steps),
            "steps",
            format!("must be in 1..=1000000, got {}", p.steps),
        )?;
        require(
            p.erodibility.is_finite() && p.erodibility >= 0.0,
            "erodibility",
            format!("must be a finite number >= 0, got {}", p.erodibility),
        )?;
        require(
            p.n.is_finite() && (0.5..=4.0).contains(&p.n),
            "n",
            format!("must be in 0.5..=4, got {}", p.n),
        )?;
        require(
            p.m.is_finite() && p.m > 0.0 && (0.3..=0.7).contains(&(p.m / p.n)),
            "m",
            format!(
                "m/n (channel concavity) must be in 0.3..=0.7, got m = {}, n = {}",
                p.m, p.n
            ),
        )?;
        require(
            p.diffusivity.is_finite() && p.diffusivity >= 0.0,
            "diffusivity",
            format!("must be a finite number >= 0, got {}", p.diffusivity),
        )?;
        if let Some(t) = p.talus_deg {
            require(
                t.is_finite() && t > 0.0 && t < 90.0,
                "talus_deg",
                format!("must be strictly between 0 and 90 degrees, got {t}"),
            )?;
        }
        Ok(())
    }
}
