# Sourced by .ci/run and .ci/web: makes sure /dev/null is the null device.
#
# Cargo's probe of rustc (`rustc - --print=...`, run at the start of a cargo
# command) takes /dev/null as its standard input and reads it as Rust
# source. Where a sandbox gives a plain file for /dev/null, that file keeps
# what is thrown away there (the cc crate's `cc -?` during a build, for
# one), and the next cargo command fails in that probe. The device is put
# back where that is allowed. Otherwise the file is made writable by all
# (apt's download methods, which drop root, cannot verify anything when
# they cannot open it), and cargo, apt-get and npm on the PATH become shims
# that empty it before each command.

null_is_device() {
  [ -c /dev/null ] && [ "$(stat -c %t:%T /dev/null)" = 1:3 ]
}

if [ -z "${QM_CI_NULL_CHECKED:-}" ] && ! null_is_device; then
  echo "ci: /dev/null is a $(stat -c %F /dev/null 2>&1), not the null device" >&2
  qm_ci_spare="/dev/.qm-ci-null.$$"
  if mknod -m 666 "$qm_ci_spare" c 1 3 && : >"$qm_ci_spare" &&
    [ -z "$(head -c 1 "$qm_ci_spare")" ] && mv -f "$qm_ci_spare" /dev/null && null_is_device; then
    echo "ci: /dev/null is the null device again" >&2
  else
    rm -f "$qm_ci_spare"
    chmod a+rw /dev/null || true
    qm_ci_shim="$(mktemp -d)"
    for qm_ci_tool in cargo apt-get npm; do
      qm_ci_real="$(command -v "$qm_ci_tool")" || continue
      # `true`, not `:`: sh leaves a script whose special builtin fails to
      # redirect (a file this user may not write), and cargo would not run.
      printf '#!/bin/sh\n[ -w /dev/null ] && true >/dev/null\nexec "%s" "$@"\n' \
        "$qm_ci_real" >"$qm_ci_shim/$qm_ci_tool"
      chmod +x "$qm_ci_shim/$qm_ci_tool"
    done
    export PATH="$qm_ci_shim:$PATH"
    echo "ci: could not replace it; cargo, apt-get and npm empty it first" >&2
  fi
fi
export QM_CI_NULL_CHECKED=1
