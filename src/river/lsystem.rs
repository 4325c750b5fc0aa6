//! Rewriting the river string (seed paper 000, Sec. IV-B, rule set Omega).

use rand::RngExt;
use rand::rngs::ChaCha12Rng;

use super::generator::{self, Sym};

/// The result of `depth` rewriting steps.
#[derive(Clone, Debug)]
pub struct Grown {
    pub symbols: Vec<Sym>,
    /// Steps actually applied (fewer than asked when the budget stopped growth).
    pub depth: u32,
    /// How often each interior generator index was chosen (index = generator).
    pub interior_choices: Vec<u64>,
    /// Why growth stopped early, in words for the user.
    pub trimmed: Option<String>,
}

/// Grows from the axiom `G` (one exterior link along the user's stroke): each step replaces
/// every exterior link by generator `phi` and every interior link by generator
/// `floor(R)` or `ceil(R)`, the fractional part of `R` (eq. 1) being the probability of the
/// ceiling. Stops before a step whose links would exceed `link_budget`.
/// Cost: O(links of the result) per step.
pub fn grow(phi: u32, depth: u32, link_budget: usize, rng: &mut ChaCha12Rng) -> Grown {
    let phi = phi.max(1);
    let r = generator::r(phi);
    let (low, frac) = (r.floor() as u32, r - r.floor());
    let exterior = generator::exterior(phi);
    let interiors = [generator::interior(low), generator::interior(low + 1)];
    let mut symbols = vec![Sym::G];
    let mut choices = vec![0u64; low as usize + 2];
    let mut trimmed = None;
    let mut done = 0;
    for step in 0..depth {
        let (f, g) = count(&symbols);
        // Each G becomes phi F + (phi + 1) G; each F at most the larger interior generator.
        let links_next = g * (2 * phi as usize + 1) + f * longest(&interiors);
        if links_next > link_budget {
            trimmed = Some(format!(
                "the river network was trimmed to {done} of {depth} iterations: iteration {} \
                 would exceed the budget of {link_budget} links (lower phi or the depth)",
                step + 1
            ));
            break;
        }
        let mut next = Vec::with_capacity(symbols.len() * 4);
        for s in &symbols {
            match s {
                Sym::G => next.extend_from_slice(&exterior),
                Sym::F => {
                    let ceil = frac > 0.0 && rng.random_bool(frac);
                    choices[low as usize + usize::from(ceil)] += 1;
                    next.extend_from_slice(&interiors[usize::from(ceil)]);
                }
                other => next.push(*other),
            }
        }
        symbols = next;
        done += 1;
    }
    Grown {
        symbols,
        depth: done,
        interior_choices: choices,
        trimmed,
    }
}

fn count(symbols: &[Sym]) -> (usize, usize) {
    symbols.iter().fold((0, 0), |(f, g), s| match s {
        Sym::F => (f + 1, g),
        Sym::G => (f, g + 1),
        _ => (f, g),
    })
}

fn longest(interiors: &[Vec<Sym>; 2]) -> usize {
    interiors
        .iter()
        .map(|g| count(g).0 + count(g).1)
        .max()
        .unwrap_or(2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// The observed mean interior generator index estimates R (Table 1); with n draws of a
    /// Bernoulli(frac) its standard error is sqrt(frac (1 - frac) / n).
    #[test]
    fn interior_generator_frequencies_match_table_1() {
        for (phi, table_r) in [(2, 1.00), (3, 1.535), (4, 1.921)] {
            let mut rng = ChaCha12Rng::seed_from_u64(42);
            let grown = grow(phi, 8, 2_000_000, &mut rng);
            let n: u64 = grown.interior_choices.iter().sum();
            assert!(n > 500, "phi {phi}: only {n} interior replacements");
            let mean = grown
                .interior_choices
                .iter()
                .enumerate()
                .map(|(k, c)| k as f64 * *c as f64)
                .sum::<f64>()
                / n as f64;
            let frac = table_r - f64::floor(table_r);
            let se = (frac * (1.0 - frac) / n as f64).sqrt().max(1e-9);
            assert!(
                (mean - table_r).abs() <= 4.0 * se + 1e-3,
                "phi {phi}: {mean} vs {table_r}"
            );
        }
    }

    #[test]
    fn absurd_settings_are_trimmed_with_a_reason() {
        let mut rng = ChaCha12Rng::seed_from_u64(1);
        let grown = grow(6, 12, 100_000, &mut rng);
        assert!(grown.depth < 12);
        let (f, g) = count(&grown.symbols);
        assert!(f + g <= 100_000);
        assert!(grown.trimmed.unwrap().contains("budget of 100000 links"));
    }

    #[test]
    fn same_seed_same_string() {
        let a = grow(3, 5, 1_000_000, &mut ChaCha12Rng::seed_from_u64(7)).symbols;
        let b = grow(3, 5, 1_000_000, &mut ChaCha12Rng::seed_from_u64(7)).symbols;
        assert_eq!(a, b);
    }
}
