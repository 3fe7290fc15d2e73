#!/usr/bin/env bash
# Starts a single-node Slurm (munge + slurmctld + slurmd from Debian's slurm-wlm and
# munge packages) on this machine, for the recipe's test (tests/cluster.rs) and CI.
# Needs root. No cgroups: ProctrackType=proctrack/linuxproc, TaskPlugin=task/none.
#
#   scripts/cluster/slurm/single-node.sh install   apt-get install slurm-wlm munge (if missing)
#   scripts/cluster/slurm/single-node.sh start     write /etc/slurm/slurm.conf, start the daemons,
#                                                 wait until the node is idle
#   scripts/cluster/slurm/single-node.sh stop      stop the daemons this script started
set -euo pipefail
conf=/etc/slurm/slurm.conf

install() {
  if command -v slurmctld >/dev/null && command -v munged >/dev/null; then return 0; fi
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -q >/dev/null
  apt-get install -y -q --no-install-recommends slurm-wlm munge >/dev/null
}

start() {
  local host cpus
  host=$(hostname -s)
  cpus=$(nproc)
  [ "$cpus" -gt 2 ] && cpus=2
  mkdir -p /run/munge /var/log/munge /var/lib/munge /etc/munge /var/spool/slurmctld /var/spool/slurmd /var/log/slurm /etc/slurm
  [ -s /etc/munge/munge.key ] || dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
  chmod 400 /etc/munge/munge.key
  chown -R munge:munge /run/munge /var/log/munge /var/lib/munge /etc/munge
  chmod 0700 /etc/munge /var/lib/munge /var/log/munge
  if ! pgrep -u munge -x munged >/dev/null; then
    runuser -u munge -- /usr/sbin/munged
  fi
  cat > "$conf" <<CONF
ClusterName=rdr
SlurmctldHost=$host
SlurmUser=root
AuthType=auth/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SwitchType=switch/none
MpiDefault=none
ReturnToService=2
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobRequeue=1
MinJobAge=300
InactiveLimit=0
KillWait=10
NodeName=$host CPUs=$cpus State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
  pgrep -x slurmctld >/dev/null || /usr/sbin/slurmctld
  pgrep -x slurmd >/dev/null || /usr/sbin/slurmd
  local i
  for i in $(seq 1 60); do
    if sinfo -h -o '%T' 2>/dev/null | grep -qE '^(idle|mixed|allocated)'; then
      echo "slurm: node $host up ($cpus CPUs)"
      return 0
    fi
    [ "$i" = 10 ] && scontrol update nodename="$host" state=resume >/dev/null 2>&1 || true
    sleep 1
  done
  echo "slurm: the node did not come up; see /var/log/slurm/" >&2
  sinfo >&2 || true
  return 1
}

stop() {
  local p
  for p in slurmd slurmctld; do
    [ -f /run/$p.pid ] && kill "$(cat /run/$p.pid)" 2>/dev/null || true
  done
}

case ${1:-} in
  install) install ;;
  start) start ;;
  stop) stop ;;
  *) sed -n '2,10p' "$0"; exit 2 ;;
esac
