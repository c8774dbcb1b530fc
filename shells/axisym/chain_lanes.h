
void condense_chain_l@LANES@(int nb, int ncells, int n, int nf, const double* E,
                    const double* weights, const int* order, int ni, const int* irow, int nv,
                    const int* vrow, double scale, double* band, int size, int* failed,
                    double* keep_l, double* keep_y);
void definite_chain_l@LANES@(int nb, int ncells, int n, int nf, const double* E,
                    const double* weights, const int* order, int ni, const int* irow, int nv,
                    const int* vrow, double scale, int size, double* band, const long* zero,
                    const long* zero_start, const long* diag, const long* diag_start, int* ok);
