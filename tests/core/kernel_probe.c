/* A Windows test program for the kernel DLL (tests/core/test_kernel_platforms.py runs it under Wine):
 *
 *     kernel_probe.exe KERNEL.dll IN.bin OUT.bin
 *
 * loads the DLL as Blender's Python would, reads one binding's layout and the control points from IN.bin (two
 * int64, the vertex and triangle counts, then the 15 arrays pbk_evaluate_f64 takes before its thread count, in
 * order, each as an int64 byte count and its bytes; a count of 0 is NULL), evaluates on two threads and writes
 * the (N, 3) float64 result to OUT.bin. Exits 0, or 1 with a message on stderr. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <windows.h>

#define N_ARRAYS 15

typedef int Evaluate(int64_t, int64_t, const void *, const void *, const void *, const void *, const void *,
                     const void *, const void *, const void *, const void *, const void *, const void *, const void *,
                     const void *, const void *, const void *, int32_t, double *);

static int fail(const char *what) {
    fprintf(stderr, "kernel_probe: %s\n", what);
    return 1;
}

int main(int argc, char **argv) {
    if (argc != 4) return fail("usage: kernel_probe KERNEL.dll IN.bin OUT.bin");
    HMODULE library = LoadLibraryA(argv[1]);
    if (!library) return fail("LoadLibrary failed");
    Evaluate *evaluate = (Evaluate *)(void *)GetProcAddress(library, "pbk_evaluate_f64");
    if (!evaluate) return fail("no pbk_evaluate_f64 in the library");
    FILE *in = fopen(argv[2], "rb");
    if (!in) return fail("cannot open the input");
    int64_t counts[2];
    void *arrays[N_ARRAYS];
    if (fread(counts, sizeof counts, 1, in) != 1) return fail("short input");
    for (int i = 0; i < N_ARRAYS; ++i) {
        int64_t size;
        if (fread(&size, sizeof size, 1, in) != 1 || size < 0) return fail("short input");
        arrays[i] = size ? malloc((size_t)size) : NULL;
        if (size && (!arrays[i] || fread(arrays[i], (size_t)size, 1, in) != 1)) return fail("short input");
    }
    fclose(in);
    double *out = malloc((size_t)counts[0] * 3 * sizeof(double));
    if (!out) return fail("out of memory");
    int status = evaluate(counts[0], counts[1], arrays[0], arrays[1], arrays[2], arrays[3], arrays[4], arrays[5],
                          arrays[6], arrays[7], arrays[8], arrays[9], arrays[10], arrays[11], arrays[12], arrays[13],
                          arrays[14], 2, out);
    if (status != 0) return fail("pbk_evaluate_f64 refused the layout");
    FILE *result = fopen(argv[3], "wb");
    if (!result || fwrite(out, sizeof(double), (size_t)counts[0] * 3, result) != (size_t)counts[0] * 3)
        return fail("cannot write the output");
    fclose(result);
    return 0;
}
