//! The Tokunaga generators of seed paper 000, Sec. IV-A and the rule set of Sec. IV-B.
//!
//! A generator replaces one link by a small binary tree: interior links `F` (the main stream)
//! and exterior links `G` (tributary tips), with `[`/`]` pushing and popping the turtle and
//! `+`/`-` turning by `theta` clockwise / counter-clockwise (`++` = `2 theta`).

/// One L-system symbol.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sym {
    /// Interior link (main stream segment).
    F,
    /// Exterior link (tributary ending in a source).
    G,
    Push,
    Pop,
    /// Rotate clockwise by theta.
    Plus,
    /// Rotate counter-clockwise by theta.
    Minus,
}

/// `P = (1 + sqrt(1 + 4 phi)) / (2 phi)` (eq. 1).
pub fn p(phi: u32) -> f64 {
    let phi = f64::from(phi.max(1));
    (1.0 + (1.0 + 4.0 * phi).sqrt()) / (2.0 * phi)
}

/// `R = P (phi - 1)` (eq. 1): the (fractional) index of the generator that replaces interior
/// links. Table 1: phi = 2, 3, 4 give 1.00, 1.535, 1.921.
pub fn r(phi: u32) -> f64 {
    p(phi) * f64::from(phi.max(1) - 1)
}

/// Link length at iteration step `t` (1-based), relative to the first: `l_t = (1 / (P phi))^(t-1)` (eq. 2).
pub fn link_length(phi: u32, t: u32) -> f64 {
    (1.0 / (p(phi) * f64::from(phi.max(1)))).powi(t.saturating_sub(1) as i32)
}

fn parse(rule: &str) -> Vec<Sym> {
    rule.chars()
        .filter_map(|c| match c {
            'F' => Some(Sym::F),
            'G' => Some(Sym::G),
            '[' => Some(Sym::Push),
            ']' => Some(Sym::Pop),
            '+' => Some(Sym::Plus),
            '-' => Some(Sym::Minus),
            _ => None,
        })
        .collect()
}

/// Generator `k` as it replaces an exterior link (rule set Omega): `k` interior links with a
/// side tributary turned `2 theta` between consecutive ones, alternating sides, and the two
/// exterior links farthest from the outlet turned `theta` either way at the tip.
/// k = 2: `F[--G]F[-G][+G]`; k = 3: `F[++G]F[--G]F[-G][+G]` (rules I and II); k = 1: `F[-G][+G]`.
pub fn exterior(k: u32) -> Vec<Sym> {
    let k = k.max(1);
    let mut rule = String::new();
    for i in 1..=k {
        rule.push('F');
        if i < k {
            // The side branch nearest the tip turns "--", the ones below alternate.
            let from_tip = k - 1 - i;
            rule.push_str(if from_tip.is_multiple_of(2) {
                "[--G]"
            } else {
                "[++G]"
            });
        }
    }
    rule.push_str("[-G][+G]");
    parse(&rule)
}

/// Generator `k` as it replaces an interior link: `FF` (k = 0, the link only lengthens),
/// `F[++G]F` (k = 1), `F[-G]F[-G][+G]` (k = 2), as in rules I and II; from k = 3 on (phi >= 5)
/// the exterior form of generator k.
pub fn interior(k: u32) -> Vec<Sym> {
    match k {
        0 => parse("FF"),
        1 => parse("F[++G]F"),
        2 => parse("F[-G]F[-G][+G]"),
        k => exterior(k),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_1_values() {
        assert!((r(2) - 1.0).abs() < 1e-3);
        assert!((r(3) - 1.535).abs() < 1e-3);
        assert!((r(4) - 1.921).abs() < 1e-3);
        assert_eq!(r(1), 0.0);
    }

    #[test]
    fn generators_have_one_more_exterior_link_than_interior() {
        for k in 1..=6 {
            let g = exterior(k);
            let f = g.iter().filter(|s| **s == Sym::F).count();
            let e = g.iter().filter(|s| **s == Sym::G).count();
            assert_eq!((f, e), (k as usize, k as usize + 1), "generator {k}");
        }
        assert_eq!(exterior(2), parse("F[--G]F[-G][+G]"));
        assert_eq!(exterior(3), parse("F[++G]F[--G]F[-G][+G]"));
    }

    #[test]
    fn links_shrink_each_step() {
        assert_eq!(link_length(2, 1), 1.0);
        assert!((link_length(2, 3) - 0.25).abs() < 1e-12);
        assert!(link_length(4, 2) < link_length(3, 2));
    }
}
