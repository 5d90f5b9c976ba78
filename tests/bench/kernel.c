/* The stepping loop of backend/elab/sim/kernel.py (`advance`) for one run, written in C
 * as the benchmark's peer (tests/bench/loop.py): the same arithmetic in the same order,
 * so the same bits (checked there). Compiled there with gcc -O3 or -O2, no fast-math
 * (it would reorder the sums); np.round is round-half-to-even, as nearbyint in the
 * default rounding mode. Arrays are C-contiguous float64 of one run's sizes. */
#include <math.h>

void advance(long n, long NX, long NY, long NC, long NZ, long E,
             const double *Ad, const double *Bd, const double *C,
             const double *Ac, const double *Bc, const double *Cc, const double *Dc,
             const double *Lw, long use_state, double u_lim, const double *quantum,
             double *x, double *xc, const double *exo,
             const double *y_op, const double *x_op, double *out)
{
    double y[16], z[16], xn[16], xcn[16];
    long W = 2 + NY + NX;
    for (long m = 0; m < NZ; m++) z[m] = 0.0;
    for (long i = 0; i < n; i++) {
        const double *ex = exo + i * E;
        double r = ex[0];
        for (long o = 0; o < NY; o++) {        /* measure */
            double acc = 0.0;
            for (long c = 0; c < NX; c++) acc += C[o * NX + c] * x[c];
            acc += ex[2 + o];
            double q = quantum[o];
            if (q > 0.0) acc = nearbyint(acc / q) * q;
            y[o] = acc;
        }
        if (use_state) for (long c = 0; c < NX; c++) z[c] = x[c];
        else for (long o = 0; o < NY; o++) z[o] = y[o];
        double v = Dc[0] * r;                   /* control_step */
        for (long m = 0; m < NZ; m++) v += Dc[1 + m] * z[m];
        for (long c = 0; c < NC; c++) v += Cc[c] * xc[c];
        v += ex[1];
        double u = v > -u_lim ? v : -u_lim;     /* min(max(v, -lim), lim) */
        u = u < u_lim ? u : u_lim;
        for (long a = 0; a < NC; a++) {
            double acc = Bc[a * (1 + NZ)] * r;
            for (long m = 0; m < NZ; m++) acc += Bc[a * (1 + NZ) + 1 + m] * z[m];
            for (long c = 0; c < NC; c++) acc += Ac[a * NC + c] * xc[c];
            xcn[a] = acc + Lw[a] * (u - v);
        }
        for (long a = 0; a < NX; a++) {         /* plant_step */
            double acc = Bd[a] * u;
            for (long c = 0; c < NX; c++) acc += Ad[a * NX + c] * x[c];
            xn[a] = acc;
        }
        double *row = out + i * W;
        row[0] = r;
        row[1] = u;
        for (long o = 0; o < NY; o++) row[2 + o] = y[o] + y_op[o];
        for (long c = 0; c < NX; c++) {
            row[2 + NY + c] = x[c] + x_op[c];
            x[c] = xn[c];
        }
        for (long c = 0; c < NC; c++) xc[c] = xcn[c];
    }
}
