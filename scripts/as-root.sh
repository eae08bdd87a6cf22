# Sourced by the setup scripts (after they define `say`): runs a command as root, through sudo
# when this is not root, or stops with a line naming the command.
as_root() {
  if [ "$(id -u)" = 0 ]; then
    "$@"
  elif command -v sudo >/dev/null; then
    sudo "$@"
  else
    say "error: need root to run: $*"
    exit 1
  fi
}
