# shells on Debian 13: the FEniCSx stack from the same package list as the host set-up.
#   scripts/docker-check   builds this daemonlessly with buildah and runs the test suite in it
FROM debian:trixie-slim
COPY deps/debian-packages.txt /tmp/debian-packages.txt
RUN apt-get update \
 && sed -e 's/#.*//' /tmp/debian-packages.txt | xargs apt-get install -y --no-install-recommends \
 && rm -rf /var/lib/apt/lists/*
ENV OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
    OMPI_MCA_btl_vader_single_copy_mechanism=none OMPI_MCA_rmaps_base_oversubscribe=1 \
    PRTE_MCA_rmaps_default_mapping_policy=:oversubscribe \
    OMP_NUM_THREADS=1 MPLBACKEND=Agg PYVISTA_OFF_SCREEN=true
COPY . /opt/shells
WORKDIR /opt/shells
RUN pip install --break-system-packages --no-deps --no-build-isolation --no-cache-dir . \
 && shells --version
CMD ["python3", "demos/main.py", "/opt/shells/results/demo"]
