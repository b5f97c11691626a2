//! Steps along a fixed direction for as long as the objective keeps falling: the doubling
//! search shared by the saddle escape and the extrapolated Newton step (`newton/escape.rs`) and
//! by a static step's descent along an unstable mode (`integrate/statics.rs`).

/// From a step `t` of value `f_t`, doubles `t` while `|2t| ≤ limit`, at most `max_doublings`
/// times, and while the value there (`value(2t)`) is below the best so far by more than
/// `margin(best)`. Returns the longest such step and its value (`(t, f_t)` when no doubling
/// improved). `value` should map a non-finite value to +∞.
pub(crate) fn double_while_falling<E>(
    mut value: impl FnMut(f64) -> Result<f64, E>,
    (t, f_t): (f64, f64),
    limit: f64,
    max_doublings: usize,
    margin: impl Fn(f64) -> f64,
) -> Result<(f64, f64), E> {
    let mut best = (t, f_t);
    for _ in 0..max_doublings {
        let t2 = 2.0 * best.0;
        if t2.abs() > limit {
            break;
        }
        let f2 = value(t2)?;
        if f2 < best.1 - margin(best.1) {
            best = (t2, f2);
        } else {
            break;
        }
    }
    Ok(best)
}

#[cfg(test)]
mod tests {
    use super::double_while_falling;

    #[test]
    fn doubles_to_the_last_step_that_lowers_a_parabola() {
        // f(t) = (t − 5)²: from t = 1 the steps 2 and 4 lower it (9, 1), 8 does not (9).
        let mut calls = 0;
        let best = double_while_falling(
            |t: f64| -> Result<f64, ()> {
                calls += 1;
                Ok((t - 5.0).powi(2))
            },
            (1.0, 16.0),
            100.0,
            usize::MAX,
            |_| 0.0,
        );
        assert_eq!(best, Ok((4.0, 1.0)));
        assert_eq!(calls, 3);
    }

    #[test]
    fn stops_at_the_limit_the_count_and_the_margin() {
        let falling = |t: f64| -> Result<f64, ()> { Ok(-t.abs()) };
        // Limit: 8 is allowed, 16 is not.
        assert_eq!(
            double_while_falling(falling, (-1.0, -1.0), 8.0, usize::MAX, |_| 0.0),
            Ok((-8.0, -8.0))
        );
        assert_eq!(
            double_while_falling(falling, (1.0, -1.0), 1e9, 2, |_| 0.0),
            Ok((4.0, -4.0))
        );
        // A decrease of 1 from −1 to −2 is not more than a margin of 1.
        assert_eq!(
            double_while_falling(falling, (1.0, -1.0), 1e9, usize::MAX, |_| 1.0),
            Ok((1.0, -1.0))
        );
    }
}
