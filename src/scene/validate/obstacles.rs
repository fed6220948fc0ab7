//! `[[obstacle]]` and `[contact]` checks.

use super::*;

impl Validator<'_> {
    /// One `[[obstacle]]`: exactly one shape, with usable numbers; friction, motion, duration.
    /// (A mesh file is read, and its problems reported, when the scene is built.)
    pub(super) fn obstacle(&mut self, i: usize, o: &ObstacleEntry) {
        let base = key!["obstacle", i];
        let at = |tail: &[Seg<'static>]| join(&base, tail);
        let shapes = [
            ("plane", o.plane.is_some()),
            ("box", o.cuboid.is_some()),
            ("sphere", o.sphere.is_some()),
            ("mesh", o.mesh.is_some()),
        ];
        let given: Vec<&str> = shapes.iter().filter(|s| s.1).map(|s| s.0).collect();
        match given.as_slice() {
            [] => self.fail(
                &base,
                "needs exactly one shape key of plane, box, sphere, mesh; got none",
            ),
            [_] => {}
            [first, second, ..] => self.fail(
                &at(&key![*second]),
                format!(
                    "needs exactly one shape key of plane, box, sphere, mesh; got {first} and {second}"
                ),
            ),
        }
        if let Some(p) = &o.plane {
            self.finite3(&at(&key!["plane", "point"]), p.point, "m");
            if !has_direction(p.normal) {
                self.fail(
                    &at(&key!["plane", "normal"]),
                    format!(
                        "must be a finite, non-zero direction (its length too), got {}",
                        vec3(p.normal)
                    ),
                );
            }
        }
        if let Some(b) = &o.cuboid {
            self.finite3(&at(&key!["box", "min"]), b.min, "m");
            self.finite3(&at(&key!["box", "max"]), b.max, "m");
            if (0..3).any(|k| b.max[k] <= b.min[k] || b.max[k].is_nan() || b.min[k].is_nan()) {
                self.fail(
                    &at(&key!["box", "max"]),
                    format!(
                        "must exceed min on every axis, got min = {}, max = {}",
                        vec3(b.min),
                        vec3(b.max)
                    ),
                );
            }
        }
        if let Some(sphere) = &o.sphere {
            self.finite3(&at(&key!["sphere", "center"]), sphere.center, "m");
            self.positive(&at(&key!["sphere", "radius"]), sphere.radius, "m");
        }
        if let Some(mesh) = &o.mesh
            && mesh.as_os_str().is_empty()
        {
            self.fail(&at(&key!["mesh"]), "must name a file");
        }
        if let Some(name) = &o.name
            && name.trim().is_empty()
        {
            self.fail(&at(&key!["name"]), "must not be empty");
        }
        if let Some(mu) = o.friction {
            self.non_negative(&at(&key!["friction"]), mu, "a Coulomb coefficient");
        }
        if let Some(m) = &o.motion {
            self.motion(&at(&key!["motion"]), m);
        }
        if let Some(d) = o.duration {
            self.non_negative(&at(&key!["duration"]), d, "s");
        }
    }

    pub(super) fn contact(&mut self, c: &ContactSpec) {
        if let Some(d) = c.distance {
            self.positive(&key!["contact", "distance"], d, "m");
        }
        self.non_negative(
            &key!["contact", "friction"],
            c.friction,
            "a Coulomb coefficient",
        );
    }
}
