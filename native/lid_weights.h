/* eyelids.fold_free_sweeps in C, included by planar_bones_kernel.c: the sweeps that move a face's lid weights
 * onto its two limits (eyelids.fold_free_weights explains them), the same steps in the same order as the numpy:
 * class after class, and within a class (faces that share no corner) face after face, which is the same as all
 * at once. The numpy reference took 0.5 s at 17k vertices, which the sweeps at 68k would multiply by eight. */

/* w (n x 2) in place; faces (F x 3), g and gf (F x 3 [x 2]), norm, lower, upper (F x 2); the classes' faces are
 * members[class_start[c] .. class_start[c + 1]), every face once. Returns the sweeps made.
 *
 * A face found within both its limits is passed over until one of its corners' weights changes: its projection
 * would move nothing (its miss is exactly 0, and a weight plus 0 is itself), so the result is the numpy's, which
 * visits every face, bit for bit; most faces settle within the first sweeps. */
PBK_EXPORT int32_t pbk_fold_free_sweeps(int64_t n_classes, const int64_t *class_start, const int64_t *members,
                                        const int32_t *faces, const double *g, const double *gf, const double *norm,
                                        const double *lower, const double *upper, double *w, int32_t sweeps,
                                        double omega, double tolerance) {
    int64_t n_faces = class_start[n_classes], n = 0;
    for (int64_t k = 0; k < 3 * n_faces; ++k) n = faces[k] + 1 > n ? faces[k] + 1 : n;
    int64_t *changed = calloc((size_t)(n > 0 ? n : 1), sizeof *changed);       /* step a weight last moved at */
    int64_t *settled = calloc((size_t)(n_faces > 0 ? n_faces : 1), sizeof *settled); /* step found within, 0: not */
    int64_t step = 0;
    int32_t made = 0;
    for (made = 1; made <= sweeps; ++made) {
        double worst = 0.0;
        for (int64_t c = 0; c < n_classes; ++c) {
            ++step;
            for (int64_t m = class_start[c]; m < class_start[c + 1]; ++m) {
                int64_t f = members[m];
                const int32_t *corner = faces + 3 * f;
                if (changed && settled && settled[f] > changed[corner[0]] && settled[f] > changed[corner[1]] &&
                    settled[f] > changed[corner[2]])
                    continue;
                int within = 1;
                for (int l = 0; l < 2; ++l) {
                    double a = g[3 * f] * w[2 * corner[0] + l] + g[3 * f + 1] * w[2 * corner[1] + l] +
                               g[3 * f + 2] * w[2 * corner[2] + l];
                    double lo = lower[2 * f + l], hi = upper[2 * f + l];
                    double target = a < lo ? lo : (a > hi ? hi : a);
                    double miss = target - a;
                    double size = fabs(miss);
                    worst = size > worst ? size : worst;
                    if (miss == 0.0) continue; /* the numpy adds 0 to each weight: the same */
                    within = 0;
                    double n_l = norm[2 * f + l];
                    double step_size = n_l > 0.0 ? miss / n_l : 0.0;
                    for (int k = 0; k < 3; ++k) {
                        double *x = w + 2 * corner[k] + l;
                        double moved = *x + omega * gf[6 * f + 2 * k + l] * step_size;
                        moved = moved < 0.0 ? 0.0 : (moved > 1.0 ? 1.0 : moved);
                        if (moved != *x && changed) changed[corner[k]] = step;
                        *x = moved;
                    }
                }
                if (within && settled) settled[f] = step;
            }
        }
        if (worst <= tolerance) break;
    }
    free(changed);
    free(settled);
    return made > sweeps ? sweeps : made;
}
