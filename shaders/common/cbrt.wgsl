// Cube root of a positive finite `a`, exact to about one ulp in f64 too:
// GLSL.std.450 pow exists in 32 bits only, so pow seeds in f32 and two Newton
// steps in `real` refine. Scaling by 2^96 (a cube, 8^32) keeps the seed inside
// the normal f32 range for every f64 input.
fn cbrt(a_in: real) -> real {
    var a = a_in;
    var scale = real(1.0);
    for (var i = 0; i < 12; i++) {
        if a > real(7.922816251426434e28) {
            a = a * real(1.2621774483536189e-29);
            scale = scale * real(4294967296.0);
        } else if a < real(1.2621774483536189e-29) {
            a = a * real(7.922816251426434e28);
            scale = scale * real(2.3283064365386963e-10);
        } else {
            break;
        }
    }
    var c = real(pow(f32(a), 1.0 / 3.0));
    c = c - (c * c * c - a) / (real(3.0) * c * c);
    c = c - (c * c * c - a) / (real(3.0) * c * c);
    return c * scale;
}
