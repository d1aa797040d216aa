//! Scene text shared by the render tests and the render bench (`benches/render.rs`
//! includes this file): the `[film]`, `[camera]` and `[sphere]` blocks every one-sphere
//! scene file opens with.

#![allow(dead_code)] // each test file uses its own subset

/// A pinhole camera: where it stands, what it looks at, its horizontal field of view in
/// degrees.
#[derive(Debug, Clone, Copy)]
pub struct Camera {
    /// The eye.
    pub position: [f64; 3],
    /// The point at the image centre.
    pub look_at: [f64; 3],
    /// Horizontal field of view, degrees.
    pub fov: f64,
}

/// `[film]` (`width`, `height`, then the `film` lines as given), `[camera]` and
/// `[sphere]` (`center`, `radius`) of a scene file; what follows (the sphere's or the
/// scene's material, a plane, lights) is the caller's.
pub fn film_camera_sphere(
    (width, height): (usize, usize),
    film: &str,
    cam: &Camera,
    center: [f64; 3],
    radius: f64,
) -> String {
    format!(
        "[film]\nwidth = {width}\nheight = {height}\n{film}\n\
         [camera]\nposition = {:?}\nlook_at = {:?}\nfov = {:?}\n\
         [sphere]\ncenter = {center:?}\nradius = {radius:?}\n",
        cam.position, cam.look_at, cam.fov
    )
}
