#define NL @LANES@
typedef double v4 __attribute__((vector_size(NL * sizeof(double))));
/* the same in memory the caller allocated: no alignment beyond a double's assumed */
typedef double v4u __attribute__((vector_size(NL * sizeof(double)), aligned(sizeof(double))));

/* One cell p for the NL lanes of weights w: the interior factor L (a, lower) and L^-1 A_iv
   (y) kept, the Schur complement's lower triangle in s. Returns the failed lanes (bit l). */
static int condense_cell(int nf, const double* E, int ncells, int n, const int* order, int p,
                         const v4* w, int ni, const int* irow, int nv, const int* vrow,
                         double scale, v4 a[NI_MAX][NI_MAX], v4 y[NI_MAX][NV_MAX],
                         v4 s[NV_MAX][NV_MAX])
{
  const long nn = (long)n * n;
  const int* ir = irow + (long)p * ni;
  const int* vr = vrow + (long)p * nv;
  const v4 zero4 = {0.0, 0.0, 0.0, 0.0};
  const double* Ec[NK_MAX];
  int bad = 0;
  for (int f = 0; f < nf; ++f) Ec[f] = E + ((long)f * ncells + order[p]) * nn;
#define ENTRY(r, c, out) { const long o_ = (long)(r) * n + (c); v4 t_ = zero4; \
    for (int f_ = 0; f_ < nf; ++f_) { t_ += w[f_] * Ec[f_][o_]; } out = t_; }
  for (int i = 0; i < ni; ++i)
  {
    for (int j = 0; j <= i; ++j) ENTRY(ir[i], ir[j], a[i][j]);
    a[i][i] *= scale;
    for (int j = 0; j < nv; ++j) ENTRY(ir[i], vr[j], y[i][j]);
  }
  for (int i = 0; i < nv; ++i)
  {
    for (int j = 0; j <= i; ++j) ENTRY(vr[i], vr[j], s[i][j]);
    s[i][i] *= scale;
  }
#undef ENTRY
  /* Cholesky a = L L^T (lower, in place), y <- L^-1 y, column by column */
  for (int k = 0; k < ni; ++k)
  {
    v4 d = a[k][k];
    for (int j = 0; j < k; ++j) d -= a[k][j] * a[k][j];
    for (int l = 0; l < NL; ++l)
    {
      if (!(d[l] > 0.0)) { bad |= 1 << l; d[l] = 1.0; }
      d[l] = sqrt(d[l]);
    }
    a[k][k] = d;
    for (int i = k + 1; i < ni; ++i)
    {
      v4 t = a[i][k];
      for (int j = 0; j < k; ++j) t -= a[i][j] * a[k][j];
      a[i][k] = t / d;
    }
    for (int j = 0; j < nv; ++j)
    {
      v4 t = y[k][j];
      for (int q = 0; q < k; ++q) t -= a[k][q] * y[q][j];
      y[k][j] = t / d;
    }
  }
  for (int i = 0; i < nv; ++i)
    for (int j = 0; j <= i; ++j)
    {
      v4 t = s[i][j];
      for (int k = 0; k < ni; ++k) t -= y[k][i] * y[k][j];
      s[i][j] = t;
    }
  return bad;
}

/* The lanes' weights for blocks g .. g + NL - 1 (lanes past the last block repeat it: their
   results are not stored). */
static void lane_weights(int nb, int nf, const double* weights, int g, v4* w)
{
  for (int l = 0; l < NL; ++l)
  {
    const int b = g + l < nb ? g + l : nb - 1;
    for (int f = 0; f < nf; ++f) w[f][l] = weights[(long)b * nf + f];
  }
}

/* Each block's Schur complement into its own band (band + b (kd + 1) size); failed[b] = 1 if
   an interior pivot of block b is not positive. With nb = 1, keep_l and keep_y (if not NULL)
   receive each chain cell's interior factor L (ni x ni, lower) and L^-1 A_iv (ni x nv), for
   solves (chain_solve). */
void condense_chain(int nb, int ncells, int n, int nf, const double* E, const double* weights,
                    const int* order, int ni, const int* irow, int nv, const int* vrow,
                    double scale, double* band, int size, int* failed, double* keep_l,
                    double* keep_y)
{
  const int kd1 = nv, half = nv / 2;
  v4 a[NI_MAX][NI_MAX], y[NI_MAX][NV_MAX], sv[NV_MAX][NV_MAX], w[NK_MAX];
  for (int b = 0; b < nb; ++b) failed[b] = 1;
  if (ni > NI_MAX || nv > NV_MAX || nf > NK_MAX) return;
  for (long i = 0; i < (long)nb * kd1 * size; ++i) band[i] = 0.0;
  for (int g = 0; g < nb; g += NL)
  {
    const int lanes = nb - g < NL ? nb - g : NL;
    int bad = 0;
    lane_weights(nb, nf, weights, g, w);
    for (int p = 0; p < ncells; ++p)
    {
      bad |= condense_cell(nf, E, ncells, n, order, p, w, ni, irow, nv, vrow, scale, a, y, sv);
      if (nb == 1 && keep_l && keep_y)
      {
        double* kl = keep_l + (long)p * ni * ni;
        double* ky = keep_y + (long)p * ni * nv;
        for (int i = 0; i < ni; ++i)
        {
          for (int j = 0; j < ni; ++j) kl[i * ni + j] = j <= i ? a[i][j][0] : 0.0;
          for (int j = 0; j < nv; ++j) ky[i * nv + j] = y[i][j][0];
        }
      }
      const long base = (long)p * half;
      for (int l = 0; l < lanes; ++l)
      {
        double* ab = band + (long)(g + l) * kd1 * size;
        for (int i = 0; i < nv; ++i)
          for (int j = 0; j <= i; ++j) ab[(i - j) + (base + j) * kd1] += sv[i][j][l];
      }
    }
    for (int l = 0; l < lanes; ++l) failed[g + l] = bad >> l & 1;
  }
}

/* Definiteness tests of nb blocks (condensed as condense_chain's, diagonals scaled by
   `scale`): the rows and columns zero[zero_start[b] ..] of block b's band set to 0 and the
   entries diag[diag_start[b] ..] to `scale`, then ok[b] = 1 if every interior pivot, every band
   entry and diagonal is finite and positive as a left-looking banded Cholesky (LAPACK's
   dpbtrf) requires, else 0. NL blocks in lockstep as in condense_chain, their bands
   interleaved (lanes innermost) in the work space band ((kd + 1) x size x NL doubles). */
void definite_chain(int nb, int ncells, int n, int nf, const double* E, const double* weights,
                    const int* order, int ni, const int* irow, int nv, const int* vrow,
                    double scale, int size, double* band_, const long* zero,
                    const long* zero_start, const long* diag, const long* diag_start, int* ok)
{
  const int kd1 = nv, kd = nv - 1, half = nv / 2;
  v4 a[NI_MAX][NI_MAX], y[NI_MAX][NV_MAX], sv[NV_MAX][NV_MAX], w[NK_MAX];
  const v4 zero4 = {0.0, 0.0, 0.0, 0.0};
  v4u* band = (v4u*)band_;  /* lanes innermost: band[i][l] */
  int good[NL];
  if (ni > NI_MAX || nv > NV_MAX || nf > NK_MAX)
  {
    for (int b = 0; b < nb; ++b) ok[b] = 0;
    return;
  }
  for (int g = 0; g < nb; g += NL)
  {
    int bad = 0;  /* bit l: lane l failed */
    lane_weights(nb, nf, weights, g, w);
    for (long i = 0; i < (long)kd1 * size; ++i) band[i] = zero4;
    for (int p = 0; p < ncells; ++p)
    {
      bad |= condense_cell(nf, E, ncells, n, order, p, w, ni, irow, nv, vrow, scale, a, y, sv);
      const long base = (long)p * half;
      for (int i = 0; i < nv; ++i)
        for (int j = 0; j <= i; ++j) band[(i - j) + (base + j) * kd1] += sv[i][j];
    }
    for (int l = 0; l < NL; ++l) good[l] = !(bad >> l & 1);
    /* each block's conditions, then the checks and the Cholesky, all lanes at once */
    for (int l = 0; l < NL; ++l)
    {
      const int b = g + l < nb ? g + l : nb - 1;
      for (long z = zero_start[b]; z < zero_start[b + 1]; ++z) band[zero[z]][l] = 0.0;
      for (long z = diag_start[b]; z < diag_start[b + 1]; ++z) band[diag[z]][l] = scale;
    }
    for (long i = 0; i < (long)kd1 * size; ++i)
      for (int l = 0; l < NL; ++l) good[l] &= isfinite(band[i][l]);
    for (int j = 0; j < size; ++j)
      for (int l = 0; l < NL; ++l) good[l] &= band[(long)j * kd1][l] > 0.0;
    bad = 0;
    for (int j = 0; j < size; ++j)
    {
      const int k0 = j - kd > 0 ? j - kd : 0;
      v4 d = band[(long)j * kd1];
      for (int k = k0; k < j; ++k)
      {
        const v4 lk = band[(j - k) + (long)k * kd1];
        d -= lk * lk;
      }
      for (int l = 0; l < NL; ++l)
      {
        if (!(d[l] > 0.0)) { bad |= 1 << l; d[l] = 1.0; }
        d[l] = sqrt(d[l]);
      }
      band[(long)j * kd1] = d;
      const int iend = j + kd < size - 1 ? j + kd : size - 1;
      for (int i = j + 1; i <= iend; ++i)
      {
        v4 t = band[(i - j) + (long)j * kd1];
        const int ks = i - kd > k0 ? i - kd : k0;
        for (int k = ks; k < j; ++k)
          t -= band[(i - k) + (long)k * kd1] * band[(j - k) + (long)k * kd1];
        band[(i - j) + (long)j * kd1] = t / d;
      }
    }
    for (int l = 0; l < NL; ++l)
      if (g + l < nb) ok[g + l] = good[l] && !(bad >> l & 1);
  }
}

#undef NL
