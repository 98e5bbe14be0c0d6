/* Binding in C, included by planar_bones_kernel.c: regions.locate (eq. 4-7, 10, 11, 14) point by point, and
 * planar_bones.bind's per-triangle `collect` (bounding-sphere and distance-bound filters, locate, eq. 9
 * weight times the mask) in one pass over the vertices. The same steps and formulas as the Python (regions.py
 * explains how eq. 4 and 6 are read), which stays the reference: tests/core/test_bind_kernel.py. At set-up of a
 * 68k-vertex face the Python took 0.3 s here.
 *
 * A triangle's frame is BIND_FRAME doubles (fused.bind_frames packs them):
 *   0 corners V0, V1, V2 (9)   9 (A^OPQ)^-1 (9, row-major)   18 unit edges e_j/|e_j| (9)   27 edge normals b_j (9)
 *   36 |e_j| (3)   39 n (3)   42 g_j = b_j . b_(j-1) (3)   45 bounding-sphere centre (3) */
#define BIND_FRAME 48
#define REGION_FACE 0
#define REGION_EDGE 1
#define REGION_APEX 4

static const int8_t CELL_REGION[8] = {REGION_FACE,     REGION_EDGE + 2, REGION_EDGE + 0, REGION_APEX + 0,
                                      REGION_EDGE + 1, REGION_APEX + 2, REGION_APEX + 1, REGION_APEX + 1};

static inline double dot3(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

typedef struct {
    int8_t region;
    double distance, face_local[3], region_local[3], apex_distance;
} Located;

/* regions.locate for one point s. */
static Located locate_point(const double *frame, const double *s) {
    const double *origin = frame, *inverse = frame + 9, *unit_edges = frame + 18, *edge_normals = frame + 27;
    const double *lengths = frame + 36, *gram_g = frame + 42;
    double d[3] = {s[0] - origin[0], s[1] - origin[1], s[2] - origin[2]};
    Located out;
    for (int k = 0; k < 3; ++k) out.face_local[k] = d[0] * inverse[k] + d[1] * inverse[3 + k] + d[2] * inverse[6 + k];
    double along[3], outward[3];
    for (int j = 0; j < 3; ++j) {
        double offset[3] = {frame[3 * j] - origin[0], frame[3 * j + 1] - origin[1], frame[3 * j + 2] - origin[2]};
        along[j] = dot3(d, unit_edges + 3 * j) - dot3(offset, unit_edges + 3 * j);        /* c_j(S), eq. 7 */
        outward[j] = dot3(d, edge_normals + 3 * j) - dot3(offset, edge_normals + 3 * j); /* (S - V_j) . b_j */
    }
    double u = out.face_local[0], v = out.face_local[1], height = out.face_local[2];
    int region = CELL_REGION[(u < 0) | ((v < 0) << 1) | (((u + v) > 1) << 2)]; /* eq. 4 */
    if (region >= REGION_APEX) { /* eq. 6 */
        int i = region - REGION_APEX, previous = (i + 2) % 3;
        if (along[previous] <= lengths[previous])
            region = REGION_EDGE + previous;
        else if (along[i] >= 0)
            region = REGION_EDGE + i;
    }
    if (region >= REGION_EDGE && region < REGION_APEX) { /* eq. 5 */
        int j = region - REGION_EDGE;
        double c = along[j];
        region = c < 0 ? REGION_APEX + j : (c > lengths[j] ? REGION_APEX + (j + 1) % 3 : REGION_EDGE + j);
    }
    out.region = (int8_t)region;
    out.region_local[0] = out.face_local[0], out.region_local[1] = out.face_local[1];
    out.region_local[2] = height;
    out.apex_distance = 0.0;
    if (region == REGION_FACE) {
        out.distance = fabs(height);
        return out;
    }
    int k = (region - 1) % 3, k_previous = (k + 2) % 3, is_apex = region >= REGION_APEX;
    double c_k = along[k], y_k = outward[k], y_previous = outward[k_previous];
    if (is_apex) {
        out.apex_distance = hypot(c_k, y_k); /* D_j(S) = |proj(S) - V_j|, eq. 14 */
        /* (a, b) on the non-orthogonal rows b_j, b_(j-1) of C_j (eq. 11) */
        double g = gram_g[k], gram = 1.0 - g * g;
        out.region_local[0] = (y_k - g * y_previous) / gram;
        out.region_local[1] = (y_previous - g * y_k) / gram;
        out.distance = hypot(height, out.apex_distance);
    } else {
        out.region_local[0] = c_k / lengths[k]; /* e_j is un-normalised in B_j, eq. 10 */
        out.region_local[1] = y_k;
        out.distance = hypot(height, y_k);
    }
    return out;
}

/* regions.distance_lower_bound for one point s. */
static double distance_bound(const double *frame, const double *s) {
    const double *corners = frame, *edge_normals = frame + 27, *normal = frame + 39;
    double height = dot3(s, normal) - dot3(corners, normal);
    double beyond = -INFINITY;
    for (int j = 0; j < 3; ++j) {
        double y = dot3(s, edge_normals + 3 * j) - dot3(corners + 3 * j, edge_normals + 3 * j);
        beyond = y > beyond ? y : beyond;
    }
    return hypot(height, beyond > 0.0 ? beyond : 0.0);
}

/* regions.locate over n points (n x 3), into the outputs (n, n, n x 3, n x 3, n). */
PBK_EXPORT void pbk_locate(int64_t n, const double *points, const double *frame, int8_t *region, double *distance,
                           double *face_local, double *region_local, double *apex_distance) {
    for (int64_t p = 0; p < n; ++p) {
        Located at = locate_point(frame, points + 3 * p);
        region[p] = at.region, distance[p] = at.distance, apex_distance[p] = at.apex_distance;
        memcpy(face_local + 3 * p, at.face_local, sizeof at.face_local);
        memcpy(region_local + 3 * p, at.region_local, sizeof at.region_local);
    }
}

/* regions.distance_lower_bound over n points, into bound (n). */
PBK_EXPORT void pbk_distance_bound(int64_t n, const double *points, const double *frame, double *bound) {
    for (int64_t p = 0; p < n; ++p) bound[p] = distance_bound(frame, points + 3 * p);
}

/* planar_bones.bind's `collect` for one triangle over the n rest vertices (n x 3, their squared norms):
 * a vertex is a candidate when its squared distance from the bounding-sphere centre is at most `reach_squared`
 * (the caller's rounding allowance included), its mask weight (mask: n, or NULL) is above 0 and its distance
 * lower bound below `bound_limit`; it is kept when its eq. 9 weight (`radius`, `exponent`) times its mask weight
 * is above 0. The kept vertices go to the outputs in vertex order (each output has room for n); returns how many. */
PBK_EXPORT int64_t pbk_collect(int64_t n, const double *rest, const double *squared_norms, const double *mask,
                               const double *frame, double reach_squared, double bound_limit, double radius,
                               double exponent, int32_t *vertex, double *weight, int8_t *region, double *face_local,
                               double *region_local, double *apex_distance) {
    const double *centre = frame + 45;
    double centre_squared = dot3(centre, centre);
    int64_t kept = 0;
    if (radius <= 0.0) return 0;
    for (int64_t u = 0; u < n; ++u) {
        const double *s = rest + 3 * u;
        if (squared_norms[u] - 2.0 * dot3(s, centre) + centre_squared > reach_squared) continue;
        if (mask && !(mask[u] > 0.0)) continue;
        if (!(distance_bound(frame, s) < bound_limit)) continue;
        Located at = locate_point(frame, s);
        if (!(at.distance < radius)) continue;
        double w = pow(0.5 * (1.0 + cos(M_PI * (at.distance / radius))), exponent); /* eq. 9 */
        if (mask) w *= mask[u];
        if (!(w > 0.0)) continue;
        vertex[kept] = (int32_t)u, weight[kept] = w, region[kept] = at.region;
        apex_distance[kept] = at.apex_distance;
        memcpy(face_local + 3 * kept, at.face_local, sizeof at.face_local);
        memcpy(region_local + 3 * kept, at.region_local, sizeof at.region_local);
        ++kept;
    }
    return kept;
}
