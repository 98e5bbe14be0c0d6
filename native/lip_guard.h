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
