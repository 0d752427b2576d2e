// Per-corner data of the solver kernels. A kernel importing this declares
// `corners: array<u32>` (CORNER_STRIDE per corner) and `shapes:
// array<vec4<real>>` (4 rows per table entry) and `x: array<real>`.

#import layout

struct CornerRef {
    b: array<vec3<real>, 4>,
    // the corner's weight in F
    w: real,
}

fn corner_ref(c: u32) -> CornerRef {
    let t = 4u * corners_get(CORNER_STRIDE * c + 4u);
    let r0 = shapes[t];
    return CornerRef(array<vec3<real>, 4>(r0.xyz, shapes[t + 1u].xyz, shapes[t + 2u].xyz, shapes[t + 3u].xyz), r0.w);
}

fn corner_point(v: u32) -> vec3<real> {
    return vec3<real>(x_get(3u * v), x_get(3u * v + 1u), x_get(3u * v + 2u));
}

fn corner_points(c: u32) -> array<vec3<real>, 4> {
    let at = CORNER_STRIDE * c;
    return array<vec3<real>, 4>(
        corner_point(corners_get(at)),
        corner_point(corners_get(at + 1u)),
        corner_point(corners_get(at + 2u)),
        corner_point(corners_get(at + 3u)),
    );
}
