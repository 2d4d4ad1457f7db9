//! Plane geometry of the friction envelope: the convex outline of a point cloud and the area of
//! a polygon.
//!
//! In: points `(x, y)`. Out: the convex hull (counter-clockwise, Andrew's monotone chain) and
//! the shoelace area. Deliberately not here: where the points come from.

/// Convex hull, counter-clockwise, without the closing point. Fewer than three distinct points
/// come back as they are (sorted, deduplicated).
pub fn convex_hull(mut pts: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    pts.retain(|(x, y)| x.is_finite() && y.is_finite());
    pts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    pts.dedup();
    if pts.len() < 3 {
        return pts;
    }
    let cross = |o: (f64, f64), a: (f64, f64), b: (f64, f64)| {
        (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
    };
    let mut lower: Vec<(f64, f64)> = Vec::new();
    for &p in &pts {
        while lower.len() >= 2 && cross(lower[lower.len() - 2], lower[lower.len() - 1], p) <= 0.0 {
            lower.pop();
        }
        lower.push(p);
    }
    let mut upper: Vec<(f64, f64)> = Vec::new();
    for &p in pts.iter().rev() {
        while upper.len() >= 2 && cross(upper[upper.len() - 2], upper[upper.len() - 1], p) <= 0.0 {
            upper.pop();
        }
        upper.push(p);
    }
    lower.pop();
    upper.pop();
    lower.extend(upper);
    lower
}

/// Area enclosed by a polygon (open or closed: a repeated first point adds nothing), by the
/// shoelace formula; always >= 0.
pub fn polygon_area(poly: &[(f64, f64)]) -> f64 {
    if poly.len() < 3 {
        return 0.0;
    }
    let twice: f64 = poly
        .iter()
        .zip(poly.iter().cycle().skip(1))
        .map(|(a, b)| a.0 * b.1 - b.0 * a.1)
        .sum();
    0.5 * twice.abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hull_of_a_square_grid_is_its_corners() {
        let pts: Vec<(f64, f64)> = (0..5)
            .flat_map(|i| (0..5).map(move |j| (i as f64, j as f64)))
            .collect();
        let hull = convex_hull(pts);
        assert_eq!(hull.len(), 4, "{hull:?}");
        for c in [(0.0, 0.0), (4.0, 0.0), (4.0, 4.0), (0.0, 4.0)] {
            assert!(hull.contains(&c));
        }
        assert_eq!(polygon_area(&hull), 16.0);
    }

    #[test]
    fn area_of_a_fine_ellipse_outline_is_pi_a_b() {
        let (a, b) = (2.5, 1.7);
        let pts: Vec<(f64, f64)> = (0..4000)
            .map(|i| {
                let t = i as f64 / 4000.0 * std::f64::consts::TAU;
                (a * t.cos(), b * t.sin())
            })
            .collect();
        let mut hull = convex_hull(pts);
        hull.push(hull[0]);
        let area = polygon_area(&hull);
        let exact = std::f64::consts::PI * a * b;
        assert!((area / exact - 1.0).abs() < 1e-5, "{area} vs {exact}");
    }

    #[test]
    fn degenerate_inputs_have_no_area() {
        assert_eq!(
            polygon_area(&convex_hull(vec![(0.0, 0.0), (1.0, 1.0)])),
            0.0
        );
        assert_eq!(
            polygon_area(&convex_hull(vec![(0.0, 0.0), (1.0, 1.0), (2.0, 2.0)])),
            0.0
        );
        assert!(convex_hull(vec![(f64::NAN, 1.0)]).is_empty());
    }
}
