//! The static geometry of a site: wall segments, with the polygons they came from.

use serde::{Deserialize, Serialize};

use super::geometry::{Point2, Polygon, Segment};
use crate::error::Result;
use crate::math::Real;

/// Static collision and sensing geometry: every wall as a segment (m, world frame).
///
/// Polygons added with [`StaticMap::add_polygon`] are stored as their edges in `segments`
/// and kept in `polygons` (for drawing and for inside tests).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct StaticMap {
    /// Every wall, including polygon edges.
    pub segments: Vec<Segment>,
    /// Solid polygons (furniture, pillars); their edges are also in `segments`.
    pub polygons: Vec<Polygon>,
}

impl StaticMap {
    /// An empty map.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a wall segment after validating it.
    pub fn add_segment(&mut self, s: Segment) -> Result<()> {
        s.validate("segment")?;
        self.segments.push(s);
        Ok(())
    }

    /// Adds a wall polyline through `points` (open), all of the same height.
    pub fn add_polyline(&mut self, points: &[Point2], height: Real) -> Result<()> {
        for w in points.windows(2) {
            self.add_segment(Segment::new(w[0], w[1], height))?;
        }
        Ok(())
    }

    /// Adds a solid polygon: its edges become walls.
    pub fn add_polygon(&mut self, p: Polygon) -> Result<()> {
        p.validate("polygon")?;
        self.segments.extend(p.edges());
        self.polygons.push(p);
        Ok(())
    }

    /// Axis-aligned bounds `([xmin, ymin], [xmax, ymax])`, or `None` for an empty map.
    pub fn bounds(&self) -> Option<(Point2, Point2)> {
        let mut it = self.segments.iter().flat_map(|s| [s.a, s.b]);
        let first = it.next()?;
        Some(it.fold((first, first), |(lo, hi), p| ([lo[0].min(p[0]), lo[1].min(p[1])], [hi[0].max(p[0]), hi[1].max(p[1])])))
    }

    /// Distance from `p` to the nearest wall (m); `inf` for an empty map.
    pub fn distance_to_point(&self, p: Point2) -> Real {
        self.segments.iter().map(|s| s.distance_to_point(p)).fold(Real::INFINITY, Real::min)
    }

    /// Whether `p` lies inside one of the solid polygons.
    pub fn inside_polygon(&self, p: Point2) -> bool {
        self.polygons.iter().any(|q| q.contains(p))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polygon_edges_become_segments() {
        let mut m = StaticMap::new();
        m.add_polygon(Polygon::rect(0.0, 0.0, 1.0, 1.0, 0.8)).unwrap();
        m.add_polyline(&[[-1.0, -1.0], [3.0, -1.0], [3.0, 2.0]], 2.0).unwrap();
        assert_eq!(m.segments.len(), 6);
        assert_eq!(m.bounds(), Some(([-1.0, -1.0], [3.0, 2.0])));
        assert!((m.distance_to_point([2.0, 0.5]) - 1.0).abs() < 1e-15);
        assert!(m.inside_polygon([0.5, 0.5]));
    }

    #[test]
    fn degenerate_polygon_is_rejected() {
        let mut m = StaticMap::new();
        let bad = Polygon { vertices: vec![[0.0, 0.0], [1.0, 0.0]], height: 1.0 };
        assert!(m.add_polygon(bad).is_err());
        assert!(m.segments.is_empty());
    }
}
