//! Universal Transverse Mercator on the WGS84 ellipsoid: longitude and latitude to a zone's
//! easting and northing and back, so that a scene placed on Earth exports a GeoTIFF in its
//! UTM zone (EPSG 326zz north, 327zz south) and GeoJSON in longitude and latitude.
//!
//! Krüger's series to sixth order in the third flattening `n`, as given by Karney (2011),
//! "Transverse Mercator with an accuracy of a few nanometers", J. Geodesy 85, eqs. 7-11 (the
//! conformal latitude), 35 (the forward series, coefficients alpha) and 36 (the inverse,
//! beta); within a zone the error is far below a millimetre. The latitude is recovered from
//! the conformal one by fixed-point iteration of its defining relation.

/// WGS84's semi-major axis (metres) and flattening.
const A: f64 = 6_378_137.0;
const F: f64 = 1.0 / 298.257_223_563;
/// UTM's scale on the central meridian and false easting (metres).
const K0: f64 = 0.9996;
const FALSE_EASTING: f64 = 500_000.0;
/// False northing of the southern hemisphere's zones (metres).
const FALSE_NORTHING_SOUTH: f64 = 10_000_000.0;

/// Latitudes UTM covers (degrees); the poles use another projection.
pub const LATITUDES: std::ops::RangeInclusive<f64> = -80.0..=84.0;

/// One UTM zone: 1..=60, six degrees of longitude each from 180 W, and a hemisphere.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Utm {
    pub zone: u8,
    pub north: bool,
}

impl Utm {
    /// The zone holding `lon`, `lat` (degrees; the standard zones, without Norway's and
    /// Svalbard's exceptions).
    pub fn for_lonlat(lon: f64, lat: f64) -> Self {
        let zone = ((lon + 180.0) / 6.0).floor().clamp(0.0, 59.0) as u8 + 1;
        Self {
            zone,
            north: lat >= 0.0,
        }
    }

    /// The zone's EPSG code on WGS84: 326zz in the north, 327zz in the south.
    pub fn epsg(&self) -> u16 {
        (if self.north { 32_600 } else { 32_700 }) + u16::from(self.zone)
    }

    /// The zone's central meridian (degrees).
    fn central_meridian(&self) -> f64 {
        f64::from(self.zone) * 6.0 - 183.0
    }

    fn false_northing(&self) -> f64 {
        if self.north {
            0.0
        } else {
            FALSE_NORTHING_SOUTH
        }
    }

    /// Easting and northing (metres) of `lon`, `lat` (degrees).
    pub fn forward(&self, lon: f64, lat: f64) -> (f64, f64) {
        let s = Series::wgs84();
        let phi = lat.to_radians();
        let lambda = (lon - self.central_meridian()).to_radians();
        let e = s.e;
        // The conformal latitude's tangent (Karney eq. 7-9).
        let t = ((phi.sin()).atanh() - e * (e * phi.sin()).atanh()).sinh();
        let xi_p = t.atan2(lambda.cos());
        let eta_p = (lambda.sin() / (1.0 + t * t).sqrt()).atanh();
        let mut xi = xi_p;
        let mut eta = eta_p;
        for (j, a) in s.alpha.iter().enumerate() {
            let k = 2.0 * (j + 1) as f64;
            xi += a * (k * xi_p).sin() * (k * eta_p).cosh();
            eta += a * (k * xi_p).cos() * (k * eta_p).sinh();
        }
        (
            FALSE_EASTING + K0 * s.big_a * eta,
            self.false_northing() + K0 * s.big_a * xi,
        )
    }

    /// Longitude and latitude (degrees) of `easting`, `northing` (metres).
    pub fn inverse(&self, easting: f64, northing: f64) -> (f64, f64) {
        let s = Series::wgs84();
        let xi = (northing - self.false_northing()) / (K0 * s.big_a);
        let eta = (easting - FALSE_EASTING) / (K0 * s.big_a);
        let mut xi_p = xi;
        let mut eta_p = eta;
        for (j, b) in s.beta.iter().enumerate() {
            let k = 2.0 * (j + 1) as f64;
            xi_p -= b * (k * xi).sin() * (k * eta).cosh();
            eta_p -= b * (k * xi).cos() * (k * eta).sinh();
        }
        let chi = (xi_p.sin() / eta_p.cosh()).asin();
        let lambda = eta_p.sinh().atan2(xi_p.cos());
        // The latitude whose conformal latitude is chi: phi = 2 atan(tan(pi/4 + chi/2)
        // ((1 + e sin phi) / (1 - e sin phi))^(e/2)) - pi/2, a contraction by e^2.
        let e = s.e;
        let conformal = (std::f64::consts::FRAC_PI_4 + chi / 2.0).tan();
        let mut phi = chi;
        for _ in 0..30 {
            let es = e * phi.sin();
            let next = 2.0 * (conformal * ((1.0 + es) / (1.0 - es)).powf(e / 2.0)).atan()
                - std::f64::consts::FRAC_PI_2;
            let done = (next - phi).abs() < 1e-15;
            phi = next;
            if done {
                break;
            }
        }
        (
            self.central_meridian() + lambda.to_degrees(),
            phi.to_degrees(),
        )
    }
}

/// The ellipsoid's eccentricity, rectifying radius and Krüger's coefficients.
struct Series {
    e: f64,
    /// The rectifying radius A of Karney eq. 14 (metres).
    big_a: f64,
    alpha: [f64; 6],
    beta: [f64; 6],
}

impl Series {
    fn wgs84() -> Self {
        let n = F / (2.0 - F);
        let (n2, n3, n4, n5, n6) = (n * n, n.powi(3), n.powi(4), n.powi(5), n.powi(6));
        let e = (F * (2.0 - F)).sqrt();
        let big_a = A / (1.0 + n) * (1.0 + n2 / 4.0 + n4 / 64.0 + n6 / 256.0);
        let alpha = [
            n / 2.0 - 2.0 / 3.0 * n2 + 5.0 / 16.0 * n3 + 41.0 / 180.0 * n4 - 127.0 / 288.0 * n5
                + 7891.0 / 37800.0 * n6,
            13.0 / 48.0 * n2 - 3.0 / 5.0 * n3 + 557.0 / 1440.0 * n4 + 281.0 / 630.0 * n5
                - 1_983_433.0 / 1_935_360.0 * n6,
            61.0 / 240.0 * n3 - 103.0 / 140.0 * n4
                + 15061.0 / 26880.0 * n5
                + 167_603.0 / 181_440.0 * n6,
            49561.0 / 161_280.0 * n4 - 179.0 / 168.0 * n5 + 6_601_661.0 / 7_257_600.0 * n6,
            34729.0 / 80640.0 * n5 - 3_418_889.0 / 1_995_840.0 * n6,
            212_378_941.0 / 319_334_400.0 * n6,
        ];
        let beta = [
            n / 2.0 - 2.0 / 3.0 * n2 + 37.0 / 96.0 * n3 - 1.0 / 360.0 * n4 - 81.0 / 512.0 * n5
                + 96199.0 / 604_800.0 * n6,
            1.0 / 48.0 * n2 + 1.0 / 15.0 * n3 - 437.0 / 1440.0 * n4 + 46.0 / 105.0 * n5
                - 1_118_711.0 / 3_870_720.0 * n6,
            17.0 / 480.0 * n3 - 37.0 / 840.0 * n4 - 209.0 / 4480.0 * n5 + 5569.0 / 90720.0 * n6,
            4397.0 / 161_280.0 * n4 - 11.0 / 504.0 * n5 - 830_251.0 / 7_257_600.0 * n6,
            4583.0 / 161_280.0 * n5 - 108_847.0 / 3_991_680.0 * n6,
            20_648_693.0 / 638_668_800.0 * n6,
        ];
        Self {
            e,
            big_a,
            alpha,
            beta,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// (lat, lon, EPSG, easting, northing) computed with pyproj 3.7.2 (PROJ's exact
    /// transverse Mercator, Poder/Engsager), `Transformer.from_crs("EPSG:4326", EPSG)`.
    #[allow(clippy::unreadable_literal)]
    const PROJ: [(f64, f64, u16, f64, f64); 9] = [
        (52.2, 0.0, 32631, 294990.6948, 5787525.7309),
        (45.0, 3.0, 32631, 500000.0, 4982950.4002),
        (-33.9, 18.4, 32734, 259583.2217, 6245888.0454),
        (64.1, -21.9, 32627, 456137.5541, 7108467.4170),
        (0.0, 3.0, 32631, 500000.0, 0.0),
        (47.5, 13.8, 32633, 409624.4512, 5261427.5492),
        (-45.0, 170.3, 32759, 444829.2903, 5016811.2856),
        (83.9, -40.0, 32624, 488136.7308, 9317033.0971),
        (-79.9, 100.0, 32747, 519576.6110, 1129407.4826),
    ];

    #[test]
    fn forward_matches_proj_to_a_millimetre() {
        for (lat, lon, epsg, e, n) in PROJ {
            let utm = Utm::for_lonlat(lon, lat);
            assert_eq!(utm.epsg(), epsg, "{lat} {lon}");
            let (x, y) = utm.forward(lon, lat);
            assert!(
                (x - e).abs() < 1e-3 && (y - n).abs() < 1e-3,
                "{lat} {lon}: {x} {y}"
            );
        }
    }

    #[test]
    fn inverse_returns_the_point_to_a_micro_degree() {
        for (lat, lon, _, e, n) in PROJ {
            let (lo, la) = Utm::for_lonlat(lon, lat).inverse(e, n);
            assert!(
                (lo - lon).abs() < 1e-8 && (la - lat).abs() < 1e-8,
                "{lat} {lon}: {la} {lo}"
            );
        }
    }
}
