# shells on Debian 13: the FEniCSx stack from the same package list as the host set-up.
#   scripts/docker-check   builds this daemonlessly with buildah and runs the test suite in it
# Two stages, as the host set-up has two envs: `paraview` (deps/paraview-packages.txt; ParaView's
# python3-paraview conflicts with python3-vtk9) only opens the field output in ParaView for the
# tests (scripts/docker-check builds it with --target paraview); the last stage is the image.

FROM debian:trixie-slim AS paraview
COPY deps/paraview-packages.txt /tmp/paraview-packages.txt
RUN apt-get update \
 && sed -e 's/#.*//' /tmp/paraview-packages.txt | xargs apt-get install -y --no-install-recommends \
 && rm -rf /var/lib/apt/lists/*
ENV SHELLS_IN_ENV=paraview
COPY . /opt/shells
WORKDIR /opt/shells

FROM debian:trixie-slim AS shells
COPY deps/debian-packages.txt /tmp/debian-packages.txt
RUN apt-get update \
 && sed -e 's/#.*//' /tmp/debian-packages.txt | xargs apt-get install -y --no-install-recommends \
 && rm -rf /var/lib/apt/lists/*
ENV OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
    OMPI_MCA_btl_vader_single_copy_mechanism=none OMPI_MCA_rmaps_base_oversubscribe=1 \
    PRTE_MCA_rmaps_default_mapping_policy=:oversubscribe \
    OMP_NUM_THREADS=1 MPLBACKEND=Agg PYVISTA_OFF_SCREEN=true \
    SHELLS_IN_ENV=1
COPY . /opt/shells
WORKDIR /opt/shells
RUN pip install --break-system-packages --no-deps --no-build-isolation --no-cache-dir . \
 && ln -s /opt/shells/scripts/demo /usr/local/bin/demo \
 && shells --version && demo >/dev/null
# `docker run` enters through scripts/in-env, which sets SHELLS_HOST_PATHS to the folders mounted
# into the container (from /proc/self/mountinfo): `shells` then refuses, before any work, a path
# that would stay inside the container. Mount the working folder at the same path:
#   docker run --rm -v "$PWD:$PWD" -w "$PWD" shells shells mesh cap --theta-deg 30 -o cap.msh
# (-e SHELLS_HOST_PATHS=/ turns the check off). `buildah run` and RUN skip the entrypoint.
ENTRYPOINT ["/usr/bin/env", "SHELLS_HOST_PATHS_FROM=mountinfo", "/opt/shells/scripts/in-env"]
# The default command lists the demos (scripts/demo); `docker run --rm shells demo NAME` runs
# one (`demo NAME --quick`: its quick mode; `demo -n 2 NAME`: on 2 MPI processes), writing to
# results/demos/NAME/ under the working folder: mount one to keep the outputs, e.g.
#   docker run --rm -v "$PWD:$PWD" -w "$PWD" shells demo fig3_sphere
CMD ["demo"]
