/* Objective-only floor for benchmarks/speed_engine.py: the helicopter fit's relative error
 * (FrequencyFit, the same arithmetic: one division per frequency, no complex types) for
 * `evals` random candidates on `n_freq` log-spaced points from 1 to 60 rad/s, in plain C.
 *
 *   gcc -O3 -march=native -o objective_floor benchmarks/objective_floor.c -lm
 *   ./objective_floor [n_freq=200] [evals=25050] [repeats=15]
 *
 * Prints one line: "median_ms min_ms" for all `evals` evaluations, one thread.
 * speed_engine.py builds and runs it itself when gcc is on the PATH. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv) {
    int nf = argc > 1 ? atoi(argv[1]) : 200, ne = argc > 2 ? atoi(argv[2]) : 25050;
    int reps = argc > 3 ? atoi(argv[3]) : 15;
    double *w = malloc(nf * sizeof *w), *w2 = malloc(nf * sizeof *w2);
    double *tr = malloc(nf * sizeof *tr), *ti = malloc(nf * sizeof *ti);
    double *wt = malloc(nf * sizeof *wt), *P = malloc(5 * (size_t)ne * sizeof *P);
    double *f = malloc(ne * sizeof *f), *t = malloc(reps * sizeof *t);
    const double lo[5] = {10, 0.01, 25, 25, 0.1}, hi[5] = {1000, 1, 625, 80, 1.5};
    const double K = 250, tau = 0.1, M = 144, ws = 38.2261, zs = 0.5118;  /* the truth */
    for (int i = 0; i < nf; i++) {
        w[i] = pow(10.0, log10(60.0) * i / (nf - 1));
        w2[i] = w[i] * w[i];
        double ar = M - w2[i], ai = w[i] / tau, br = ws * ws - w2[i], bi = 2 * zs * ws * w[i];
        double dr = ar * br - ai * bi, di = ar * bi + ai * br, s = K * ws * ws / (dr * dr + di * di);
        tr[i] = s * dr;
        ti[i] = -s * di;
        wt[i] = 1.0 / ((tr[i] * tr[i] + ti[i] * ti[i]) * nf);
    }
    srand(1);
    for (int e = 0; e < ne; e++)
        for (int d = 0; d < 5; d++) P[5 * e + d] = lo[d] + (hi[d] - lo[d]) * rand() / (double)RAND_MAX;
    volatile double sink = 0;
    for (int r = 0; r < reps; r++) {
        double t0 = now();
        for (int e = 0; e < ne; e++) {
            const double *x = P + 5 * e;
            double itau = 1.0 / x[1], s2 = x[3] * x[3], c = 2 * x[4] * x[3], num = x[0] * s2;
            double a0 = x[2] * s2, a2 = x[2] + s2 + c * itau, b1 = x[2] * c + s2 * itau, b3 = c + itau;
            double acc = 0;
            for (int i = 0; i < nf; i++) {
                double dr = (w2[i] - a2) * w2[i] + a0, di = (b1 - b3 * w2[i]) * w[i];
                double er = num - (tr[i] * dr - ti[i] * di), ei = tr[i] * di + ti[i] * dr;
                acc += (er * er + ei * ei) * wt[i] / (dr * dr + di * di);
            }
            f[e] = acc;
        }
        t[r] = now() - t0;
        sink += f[ne / 2];
    }
    qsort(t, reps, sizeof *t, cmp);
    printf("%.4f %.4f\n", t[reps / 2] * 1e3, t[0] * 1e3);
    return sink != sink;
}
