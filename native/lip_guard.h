/* The lip guard of addon/deform/lips.py (`guard_lips`, `seam`, `_bound`) in one pass, included by
 * planar_bones_kernel.c: the same sums and clamps in double, with no per-call overhead (the numpy version makes
 * some forty calls on small arrays each frame). lips.py's notes say what the seam and the bounds are; this
 * follows its steps one for one, and tests hold the two equal. */

#define GUARD_KNOTS 17 /* lips.N_KNOTS */
#define GUARD_ENDS 5   /* lips.ENDS: the seam's point, then the chords' ends, half-widths 0.5 and 1 */
#define GUARD_GRID (GUARD_ENDS * GUARD_KNOTS)
static const double guard_ends[GUARD_ENDS] = {0.0, -0.5, 0.5, -1.0, 1.0};
static const double guard_shifts[GUARD_ENDS] = {-1.0, -0.5, 0.0, 0.5, 1.0}; /* lips.SHIFTS: the ends, sorted */

/* numpy.interp: fp at x on the polyline (xp, fp), xp non-decreasing, held flat beyond its ends. */
static double interp(double x, const double *xp, const double *fp, int n) {
    if (x != x) return x;
    if (x < xp[0]) return fp[0];
    if (x >= xp[n - 1]) return fp[n - 1];
    /* lo = the last i with xp[i] <= x (then x < xp[lo + 1]), by halving without branches: a vertex's x is
     * anywhere on the grid, and a mispredicted branch per halving cost more than the rest of the guard */
    int lo = 0;
    for (int len = n - 1; len > 1;) {
        int half = len / 2;
        lo = xp[lo + half] <= x ? lo + half : lo;
        len -= half;
    }
    double slope = (fp[lo + 1] - fp[lo]) / (xp[lo + 1] - xp[lo]);
    double value = slope * (x - xp[lo]) + fp[lo];
    if (value != value) { /* as numpy: try from the other end, then a flat piece */
        value = slope * (x - xp[lo + 1]) + fp[lo + 1];
        if (value != value && fp[lo] == fp[lo + 1]) value = fp[lo];
    }
    return value;
}

/* numpy.interp at ascending x, walking along xp instead of searching it anew for each. */
static void interp_ascending(const double *x, int n_x, const double *xp, const double *fp, int n, double *out) {
    int lo = 0;
    for (int i = 0; i < n_x; ++i) {
        double at = x[i];
        if (at != at || at < xp[0] || at >= xp[n - 1]) {
            out[i] = interp(at, xp, fp, n);
            continue;
        }
        while (lo + 1 < n && xp[lo + 1] <= at) ++lo; /* xp[lo] <= at < xp[lo + 1] */
        double slope = (fp[lo + 1] - fp[lo]) / (xp[lo + 1] - xp[lo]);
        double value = slope * (at - xp[lo]) + fp[lo];
        out[i] = value == value ? value : interp(at, xp, fp, n);
    }
}

/* The sorted union of GUARD_ENDS copies of the non-decreasing kx, shifted by shifts[s] * r (a merge). */
static void shifted_grid(const double *kx, double r, double *grid) {
    int next[GUARD_ENDS] = {0};
    for (int g = 0; g < GUARD_GRID; ++g) {
        int best = -1;
        double least = INFINITY;
        for (int s = 0; s < GUARD_ENDS; ++s) {
            if (next[s] == GUARD_KNOTS) continue;
            double v = kx[next[s]] + guard_shifts[s] * r;
            if (best < 0 || v < least) best = s, least = v;
        }
        grid[g] = least;
        ++next[best];
    }
}

/* Keep each guarded lip vertex on its side of the seam, in place on out (N, 3); see lips.guard_lips.
 * vertices, side, slack: (V,) the guard's; order, starts: the runs of lip vertices near each of the n_runs
 * guarded knots `knots` (the upper lip's runs, then the lower's; starts has 2 n_runs + 1 entries, the last
 * the length of order); spread (17, M)
 * the seam's knots as weights of the control points (M, 3) `points`; axes (3, 3) the face frame; reach (2,)
 * the widest triangle of the lower and upper lip across; width the seam's width at rest; skin (n_skin,) the guarded
 * vertices, then the skin beside them that follows, sources and shares (n_sources, n_skin) whose push each shares
 * and how much (lips._carry). scratch: 2 V doubles. */
static int guard(int single, int64_t n_guarded, const int32_t *vertices, const double *side, const double *slack,
                  int64_t n_runs, const int32_t *knots, const int32_t *order, const int32_t *starts,
                  const double *spread, int64_t n_points, const double *points, const double *axes,
                  const double *reach, double width, int64_t n_skin, const int32_t *skin, int64_t n_sources,
                  const int32_t *sources, const double *shares, double *scratch, void *output) {
    float *out32 = output;
    double *out64 = output;
    double *x = scratch, *signed_y = scratch + n_guarded;
    for (int64_t i = 0; i < n_guarded; ++i) {
        int64_t v = 3 * (int64_t)vertices[i];
        double p[3];
        for (int k = 0; k < 3; ++k) p[k] = single ? (double)out32[v + k] : out64[v + k];
        x[i] = axes[0] * p[0] + axes[1] * p[1] + axes[2] * p[2];
        signed_y[i] = side[i] * (axes[3] * p[0] + axes[4] * p[1] + axes[5] * p[2]);
    }
    /* lips.seam: the knots from the control points, x made non-decreasing, y moved between the lips */
    double kx[GUARD_KNOTS], ky[GUARD_KNOTS];
    for (int k = 0; k < GUARD_KNOTS; ++k) {
        double q[3] = {0.0, 0.0, 0.0};
        for (int64_t m = 0; m < n_points; ++m) {
            double w = spread[k * n_points + m];
            if (w != 0.0)
                for (int c = 0; c < 3; ++c) q[c] += w * points[3 * m + c];
        }
        kx[k] = axes[0] * q[0] + axes[1] * q[1] + axes[2] * q[2];
        ky[k] = axes[3] * q[0] + axes[4] * q[1] + axes[5] * q[2];
        if (k > 0 && kx[k] < kx[k - 1]) kx[k] = kx[k - 1];
    }
    for (int64_t j = 0; j < n_runs; ++j) {
        double least[2];
        for (int lip = 0; lip < 2; ++lip) {
            int64_t run = lip * n_runs + j;
            least[lip] = INFINITY;
            for (int64_t r = starts[run]; r < starts[run + 1]; ++r)
                if (signed_y[order[r]] < least[lip]) least[lip] = signed_y[order[r]];
        }
        double high = least[0], low = -least[1];
        double lower = low < high ? low : high, upper = low > high ? low : high;
        double y = ky[knots[j]];
        y = y > lower ? y : lower;
        ky[knots[j]] = y < upper ? y : upper;
    }
    /* lips._bound: per lip, the seam and the other lip's chords sampled where they bend */
    double stretch = (kx[GUARD_KNOTS - 1] - kx[0]) / width;
    stretch = stretch > 1.0 ? stretch : 1.0;
    double grid[2][GUARD_GRID], envelope[2][GUARD_GRID];
    for (int lip = 0; lip < 2; ++lip) { /* 0: the upper lip's bound (the lower lip's reach), 1: the lower's */
        double r = reach[lip] * stretch, at[GUARD_GRID], e[GUARD_ENDS][GUARD_GRID];
        shifted_grid(kx, r, grid[lip]);
        for (int s = 0; s < GUARD_ENDS; ++s) {
            for (int g = 0; g < GUARD_GRID; ++g) at[g] = grid[lip][g] + guard_ends[s] * r;
            interp_ascending(at, GUARD_GRID, kx, ky, GUARD_KNOTS, e[s]);
        }
        for (int g = 0; g < GUARD_GRID; ++g) {
            double heights[3] = {e[0][g], 0.5 * (e[1][g] + e[2][g]), 0.5 * (e[3][g] + e[4][g])};
            double best = -INFINITY;
            for (int h = 0; h < 3; ++h) {
                double signed_height = lip == 0 ? heights[h] : -heights[h];
                if (signed_height > best) best = signed_height;
            }
            envelope[lip][g] = best;
        }
    }
    /* a vertex past the seam (more than at rest) goes straight along the face's up back onto it, and the skin
     * beside it follows with its shares of the pushes (each push in place of the vertex's x, used no more) */
    double *push = x;
    int any = 0;
    for (int64_t i = 0; i < n_guarded; ++i) {
        int lip = side[i] > 0.0 ? 0 : 1;
        double past = slack[i] - signed_y[i] + interp(x[i], grid[lip], envelope[lip], GUARD_GRID);
        push[i] = past > 0.0 ? past : 0.0;
        any |= past > 0.0;
    }
    if (!any) return 0;
    for (int64_t j = 0; j < n_skin; ++j) {
        double step = 0.0;
        for (int64_t k = 0; k < n_sources; ++k) { /* numpy's sum over axis 0: row by row */
            double term = shares[k * n_skin + j] * push[sources[k * n_skin + j]];
            step = k == 0 ? term : step + term;
        }
        if (j < n_guarded) step = side[j] * (push[j] > step ? push[j] : step);
        if (step == 0.0) continue;
        int64_t v = 3 * (int64_t)skin[j];
        for (int k = 0; k < 3; ++k) {
            if (axes[3 + k] == 0.0) continue;
            if (single)
                out32[v + k] = (float)((double)out32[v + k] + step * axes[3 + k]);
            else
                out64[v + k] += step * axes[3 + k];
        }
    }
    return 1;
}

/* `single`: out is float32 (else float64). Returns 0 (no vertex moved), 2 (some moved), or 1 for bad counts (out
 * untouched). */
PBK_EXPORT int pbk_guard_lips(int32_t single, int64_t n_guarded, const int32_t *vertices, const double *side,
                              const double *slack, int64_t n_runs, const int32_t *knots, const int32_t *order,
                              const int32_t *starts, const double *spread, int64_t n_points, const double *points,
                              const double *axes, const double *reach, double width, int64_t n_skin,
                              const int32_t *skin, int64_t n_sources, const int32_t *sources, const double *shares,
                              double *scratch, void *out) {
    if (n_guarded < 0 || n_runs < 0 || n_points < 0 || n_skin < n_guarded || n_sources < 0) return 1;
    return 2 * guard(single != 0, n_guarded, vertices, side, slack, n_runs, knots, order, starts, spread, n_points,
                     points, axes, reach, width, n_skin, skin, n_sources, sources, shares, scratch, out);
}

/* ---------------------------------------------------------------------------------------------------------------
 * Keep Lips Apart's contact (lips.press_apart, its numpy reference, and lips._along, lips._push_along): where the
 * seam does not part the lips, each sample of the contact (a vertex, or the middle of an edge between two) is kept
 * out of the other lip's flesh, looking along its own direction into its lip for the other lip's triangles as
 * deformed. The same sums in the same order as the numpy, so the same result bit for bit where the compiler does
 * not fuse a multiply and an add (x86-64's baseline has no FMA): the (sample, triangle) pairs looked at are those
 * whose boxes meet (the stretch looked along, the triangle's), as numpy's bins of x find them, here found through
 * the triangles sorted by their boxes' least x (kept sorted from call to call: an insertion sort of an order that
 * barely changes) and the running largest of their boxes' greatest x, and a sample's depth is the least of its
 * pairs' distances, which does not depend on the order they are met in. */

#define CONTACT_EDGE_ON 1e-9    /* lips.EDGE_ON */
#define CONTACT_EDGE_SLACK 1e-9 /* lips.EDGE_SLACK */

/* row r of the face frame `axes` (3, 3) at the mesh point p: lips._in_frame's sum, in its order */
static inline double contact_row(const double *axes, int r, const double *p) {
    return p[0] * axes[3 * r] + p[1] * axes[3 * r + 1] + p[2] * axes[3 * r + 2];
}

/* vertex v of out (float32 or float64) in the face frame */
static inline void contact_face_point(int single, const void *out, int64_t v, const double *axes, double *face) {
    double p[3];
    for (int c = 0; c < 3; ++c) p[c] = single ? (double)((const float *)out)[3 * v + c] : ((const double *)out)[3 * v + c];
    for (int r = 0; r < 3; ++r) face[r] = contact_row(axes, r, p);
}

/* The pair (start, direction d) and the triangle of corners c (9): where the line meets the triangle at a t in
 * [0, reach], the least such t so far (*first) and whether a triangle facing along d meets it there (*along). */
static inline void contact_pair(const double *start, const double *d, const double *c, double reach, double *first,
                                int *along) {
    double ax = c[0], ay = c[1], az = c[2];
    double e1x = c[3] - ax, e1y = c[4] - ay, e1z = c[5] - az;
    double e2x = c[6] - ax, e2y = c[7] - ay, e2z = c[8] - az;
    double dx = d[0], dy = d[1], dz = d[2];
    double hx = dy * e2z - dz * e2y, hy = dz * e2x - dx * e2z, hz = dx * e2y - dy * e2x;
    double det = e1x * hx + e1y * hy + e1z * hz;
    double square = (e1x * e1x + e1y * e1y + e1z * e1z) * (e2x * e2x + e2y * e2y + e2z * e2z);
    if (!(det * det > CONTACT_EDGE_ON * CONTACT_EDGE_ON * square)) return; /* seen edge-on */
    double inv = 1.0 / det;
    double sx = start[0] - ax, sy = start[1] - ay, sz = start[2] - az;
    double u = inv * (sx * hx + sy * hy + sz * hz);
    double qx = sy * e1z - sz * e1y, qy = sz * e1x - sx * e1z, qz = sx * e1y - sy * e1x;
    double v = inv * (dx * qx + dy * qy + dz * qz);
    double t = inv * (e2x * qx + e2y * qy + e2z * qz);
    if (!(u >= -CONTACT_EDGE_SLACK && v >= -CONTACT_EDGE_SLACK && u + v <= 1.0 + CONTACT_EDGE_SLACK)) return;
    if (!(t >= 0.0 && t <= reach)) return;
    if (t < *first) {
        *first = t;
        *along = det < 0.0;
    } else if (t == *first) {
        *along |= det < 0.0;
    }
}

/* do the boxes low-high (3) and box_low-box_high (3) meet (closed, as lips._boxes_meeting) */
static inline int contact_meet(const double *low, const double *high, const double *box_low, const double *box_high) {
    return low[0] <= box_high[0] && high[0] >= box_low[0] && low[1] <= box_high[1] && high[1] >= box_low[1] &&
           low[2] <= box_high[2] && high[2] >= box_low[2];
}

/* doubles of scratch pbk_press_apart needs for n_contact vertices, n_samples samples, n_triangles triangles and
 * n_guarded guarded vertices */
PBK_EXPORT int64_t pbk_press_apart_scratch(int64_t n_contact, int64_t n_samples, int64_t n_triangles, int64_t n_guarded) {
    return 4 * n_contact + 10 * n_samples + 16 * n_triangles + 4 * n_guarded;
}

/* lips.press_apart in place on out (N, 3; float32 when `single`, else float64). The contact (lips.Contact):
 * vertices, rows (n_contact) its mesh vertices and their rows among the guarded vertices; ends (n_samples, 2),
 * look, keep (n_samples), direction (n_samples, 3) its samples; triangles (n_triangles, 3) the other lips' skin,
 * the first n_first facing 1 (the lower lip's, looked at by the samples whose look is 1), the rest -1; reach how
 * far along a direction they are looked for. axes (3, 3) the face frame; the carry (lips._carry): n_guarded, skin
 * (n_skin), sources and shares (n_sources, n_skin). order (n_triangles): within each facing, a permutation of its
 * triangles, kept by the caller from call to call (the kernel keeps it sorted by the boxes' least x). scratch:
 * pbk_press_apart_scratch doubles. Returns 0 (no vertex moved), 2 (some moved), or 1 for bad counts (out
 * untouched). */
PBK_EXPORT int pbk_press_apart(int32_t single, int64_t n_contact, const int32_t *vertices, const int32_t *rows,
                               int64_t n_samples, const int32_t *ends, const double *look, const double *keep,
                               const double *direction, int64_t n_triangles, int64_t n_first, const int32_t *triangles,
                               double reach, const double *axes, int64_t n_guarded, int64_t n_skin, const int32_t *skin,
                               int64_t n_sources, const int32_t *sources, const double *shares, int32_t *order,
                               double *scratch, void *out) {
    if (n_contact < 0 || n_samples < 0 || n_triangles < 0 || n_first < 0 || n_first > n_triangles || n_guarded < 0 ||
        n_skin < n_guarded || n_sources < 0)
        return 1;
    double *face = scratch;                   /* 3 n_contact: the contact's vertices in the face frame */
    double *start = face + 3 * n_contact;     /* 3 n_samples: where each sample looks from */
    double *lacks = start + 3 * n_samples;    /* n_samples: its depth, then how much it lacks */
    double *low = lacks + n_samples;          /* 3 n_samples, then 3 n_samples: its stretch's box */
    double *high = low + 3 * n_samples;       /* (numpy's middle -+ reach_box) */
    double *corners = low + 6 * n_samples;    /* 9 n_triangles: the triangles' corners in the face frame */
    double *box_low = corners + 9 * n_triangles, *box_high = box_low + 3 * n_triangles; /* 3 n_triangles each */
    double *reach_x = box_high + 3 * n_triangles; /* n_triangles: the largest box_high x up to each of `order` */
    double *push = reach_x + n_triangles;     /* n_guarded */
    double *along = push + n_guarded;         /* 3 n_guarded */
    double *most = along + 3 * n_guarded;     /* n_contact */
    for (int64_t i = 0; i < n_contact; ++i) contact_face_point(single, out, vertices[i], axes, face + 3 * i);
    /* each sample: midway between its ends, looked from as far back as it was clear of the other lip at rest */
    int usable[2] = {n_first > 0, n_triangles - n_first > 0};
    if (!isfinite(reach)) usable[0] = usable[1] = 0;
    double half = 0.5 * reach;
    for (int64_t s = 0; s < n_samples; ++s) {
        const double *a = face + 3 * (int64_t)ends[2 * s], *b = face + 3 * (int64_t)ends[2 * s + 1];
        const double *d = direction + 3 * s;
        double back = keep[s] < 0.0 ? keep[s] : 0.0;
        int group = look[s] > 0.0 ? 0 : 1;
        for (int c = 0; c < 3; ++c) {
            double p = (a[c] + b[c]) / 2.0;
            start[3 * s + c] = p + back * d[c];
            if (!isfinite(start[3 * s + c])) usable[group] = 0; /* as lips._along: none is looked for */
        }
        for (int c = 0; c < 3; ++c) {
            double middle = start[3 * s + c] + half * d[c], box = half * fabs(d[c]);
            low[3 * s + c] = middle - box;
            high[3 * s + c] = middle + box;
        }
    }
    /* the triangles in the face frame, their boxes, and, per facing, their order by the boxes' least x */
    int finite[2] = {1, 1};
    for (int64_t t = 0; t < n_triangles; ++t) {
        double *c = corners + 9 * t;
        for (int j = 0; j < 3; ++j) contact_face_point(single, out, triangles[3 * t + j], axes, c + 3 * j);
        for (int k = 0; k < 3; ++k) {
            double lo = c[k], hi = c[k];
            for (int j = 1; j < 3; ++j) {
                lo = c[3 * j + k] < lo ? c[3 * j + k] : lo;
                hi = c[3 * j + k] > hi ? c[3 * j + k] : hi;
            }
            box_low[3 * t + k] = lo, box_high[3 * t + k] = hi;
        }
        for (int k = 0; k < 9; ++k)
            if (!isfinite(c[k])) finite[t < n_first ? 0 : 1] = 0;
    }
    int64_t first_of[3] = {0, n_first, n_triangles};
    for (int g = 0; g < 2; ++g) {
        if (!finite[g]) continue;
        for (int64_t i = first_of[g] + 1; i < first_of[g + 1]; ++i) { /* insertion sort: the order barely changes */
            int32_t t = order[i];
            double key = box_low[3 * (int64_t)t];
            int64_t j = i;
            for (; j > first_of[g] && box_low[3 * (int64_t)order[j - 1]] > key; --j) order[j] = order[j - 1];
            order[j] = t;
        }
        double most = -INFINITY;
        for (int64_t i = first_of[g]; i < first_of[g + 1]; ++i) {
            double x = box_high[3 * (int64_t)order[i]];
            most = x > most ? x : most;
            reach_x[i] = most;
        }
    }
    /* each sample's depth into the other lip: the nearest of the other lip's surfaces ahead, where it faces along */
    int any = 0;
    for (int64_t s = 0; s < n_samples; ++s) {
        int g = look[s] > 0.0 ? 0 : 1;
        double first = INFINITY;
        int facing = 0;
        if (usable[g]) {
            const double *lo = low + 3 * s, *hi = high + 3 * s;
            if (finite[g]) {
                int64_t a = first_of[g], b = first_of[g + 1]; /* the first whose running greatest x reaches lo */
                while (a < b) {
                    int64_t m = a + (b - a) / 2;
                    if (reach_x[m] >= lo[0])
                        b = m;
                    else
                        a = m + 1;
                }
                for (int64_t i = a; i < first_of[g + 1] && box_low[3 * (int64_t)order[i]] <= hi[0]; ++i) {
                    int64_t t = order[i];
                    if (contact_meet(lo, hi, box_low + 3 * t, box_high + 3 * t))
                        contact_pair(start + 3 * s, direction + 3 * s, corners + 9 * t, reach, &first, &facing);
                }
            } else { /* a position not a number: every triangle, each meeting the box or not as numpy's would */
                for (int64_t t = first_of[g]; t < first_of[g + 1]; ++t)
                    if (contact_meet(lo, hi, box_low + 3 * t, box_high + 3 * t))
                        contact_pair(start + 3 * s, direction + 3 * s, corners + 9 * t, reach, &first, &facing);
            }
        }
        double depth = facing && isfinite(first) ? first : 0.0;
        double kept = keep[s] > 0.0 ? keep[s] : 0.0;
        double lack = depth - kept;
        lacks[s] = lack > 0.0 ? lack : 0.0;
        any |= lacks[s] > 0.0;
    }
    if (!any) return 0;
    /* each contact vertex moves by the most any of its samples lacks, along the samples' directions weighted by
     * what each lacks; then the guarded vertices' pushes spread to the skin beside them (lips._push_along) */
    for (int64_t i = 0; i < n_guarded; ++i) push[i] = 0.0, along[3 * i] = along[3 * i + 1] = along[3 * i + 2] = 0.0;
    double *moves = face; /* 3 n_contact, once the vertices' positions are used */
    for (int64_t i = 0; i < n_contact; ++i) most[i] = 0.0, moves[3 * i] = moves[3 * i + 1] = moves[3 * i + 2] = 0.0;
    for (int k = 0; k < 2; ++k)
        for (int64_t s = 0; s < n_samples; ++s) {
            int64_t i = ends[2 * s + k];
            most[i] = lacks[s] > most[i] ? lacks[s] : most[i];
            for (int c = 0; c < 3; ++c) moves[3 * i + c] += lacks[s] * direction[3 * s + c];
        }
    for (int64_t i = 0; i < n_contact; ++i) {
        const double *m = moves + 3 * i;
        double norm = sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
        norm = norm > 1e-300 ? norm : 1e-300;
        int64_t r = rows[i];
        push[r] = most[i];
        for (int c = 0; c < 3; ++c) along[3 * r + c] = m[c] / norm;
    }
    float *out32 = out;
    double *out64 = out;
    for (int64_t j = 0; j < n_skin; ++j) {
        double step[3] = {0.0, 0.0, 0.0};
        for (int64_t k = 0; k < n_sources; ++k) {
            int64_t from = sources[k * n_skin + j];
            double weight = fabs(shares[k * n_skin + j]) * push[from];
            for (int c = 0; c < 3; ++c) {
                double term = weight * along[3 * from + c];
                step[c] = k == 0 ? term : step[c] + term;
            }
        }
        if (j < n_guarded) { /* its own push, where the shared move falls short */
            const double *d = along + 3 * j;
            double shortfall = push[j] - (step[0] * d[0] + step[1] * d[1] + step[2] * d[2]);
            shortfall = shortfall > 0.0 ? shortfall : 0.0;
            for (int c = 0; c < 3; ++c) step[c] = step[c] + d[c] * shortfall;
        }
        if (step[0] == 0.0 && step[1] == 0.0 && step[2] == 0.0) continue;
        int64_t v = 3 * (int64_t)skin[j];
        for (int m = 0; m < 3; ++m) {
            double delta = step[0] * axes[m] + step[1] * axes[3 + m] + step[2] * axes[6 + m];
            if (single)
                out32[v + m] = out32[v + m] + (float)delta;
            else
                out64[v + m] = out64[v + m] + delta;
        }
    }
    return 2;
}
