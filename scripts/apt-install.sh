# Sourced by scripts/setup-gpu and scripts/setup-oracle (not run on its own): apt_install PKG...
# installs Debian packages when run as root where apt-get exists (else returns 1), running
# `apt-get update` once per script. The caller defines say().
is_root() { [[ "$(id -u)" == "0" ]]; }
APT_UPDATED=0
# Another apt or dpkg run (an unattended upgrade, the other set-up script) holds the lock for a
# while: wait for it rather than fail.
APT_WAIT=(-o DPkg::Lock::Timeout=600)
apt_install() {
    if ! is_root || ! command -v apt-get >/dev/null 2>&1; then return 1; fi
    if [[ "$APT_UPDATED" == "0" ]]; then
        say "apt-get update"
        DEBIAN_FRONTEND=noninteractive apt-get "${APT_WAIT[@]}" update -qq >/dev/null || return 1
        APT_UPDATED=1
    fi
    say "apt-get install $*"
    DEBIAN_FRONTEND=noninteractive apt-get "${APT_WAIT[@]}" install -y -qq "$@" >/dev/null || return 1
}
