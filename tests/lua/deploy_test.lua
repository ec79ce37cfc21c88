-- dca.deploy: the texts `dca deploy` writes (docs/deploy.md), as pure functions: ExecStart's quoting, the TCP
-- hosts of a fleet, each daemon's options, and what is refused (a host without an address, a Unix address).
local T = require "dca.testing"
local deploy = require "dca.deploy"
local suite = T.suite("deploy")

suite:case("exec_args_are_quoted_as_systemd_reads_them", function()
  T.eq(deploy.exec_arg("10.0.0.2:7000"), "10.0.0.2:7000")
  T.eq(deploy.exec_arg("[fd00::4]:7000"), "[fd00::4]:7000")
  T.eq(deploy.exec_arg("two words"), '"two words"')
  T.eq(deploy.exec_arg('say "hi"'), '"say \\"hi\\""')
  T.eq(deploy.exec_arg("a\\b"), '"a\\\\b"')
  T.eq(deploy.exec_arg("50%"), "50%%")           -- not a specifier
  T.eq(deploy.exec_arg("$HOME"), "$$HOME")       -- not a variable
  T.eq(deploy.exec_arg(""), '""')
end)

suite:case("a_fleet_is_on_tcp", function()
  T.eq(deploy.tcp_host("10.0.0.2:7000"), "10.0.0.2")
  T.eq(deploy.tcp_host("[fd00::4]:7000"), "fd00::4")
  T.eq(deploy.tcp_host("tcp:10.0.0.2:7000"), "10.0.0.2")
  T.eq(deploy.tcp_host("localhost:7000"), "localhost")
  T.eq(deploy.tcp_host("arm.lab:7000"), nil)  -- the daemon takes numeric addresses only
  T.eq(deploy.tcp_host("unix:/run/dca/d.sock"), nil)
  T.eq(deploy.tcp_host("10.0.0.2"), nil)
  local files, err = deploy.files({ "arm", "base" }, { arm = "10.0.0.2:7000" }, { system = "s.dca", hosts_file = "h" })
  T.eq(files, nil)
  T.eq(err, "no address for host 'base' in h")
  files, err = deploy.files({ "arm" }, { arm = "unix:/run/a.sock" }, { system = "s.dca", hosts_file = "h" })
  T.eq(files, nil)
  T.contains(err, "host 'arm' in h: 'unix:/run/a.sock' is not a TCP address")
end)

suite:case("each_daemon_listens_on_its_address_with_every_other_host_as_a_peer", function()
  local files, list = deploy.files({ "b", "a", "c" }, { a = "10.0.0.1:7000", b = "10.0.0.2:7000", c = "10.0.0.3:7001" },
    { system = "s.dca", hosts_file = "h" })
  T.eq(#list, 3)
  local unit = files["units/b/dca-daemon.service"]
  T.contains(unit, "\nExecStart=/usr/bin/dca daemon --key /etc/dca/key --state-dir %S/dca --host b --listen "
    .. "10.0.0.2:7000 --peer 10.0.0.1:7000 --peer 10.0.0.3:7001\n")
  T.contains(unit, "Description=dca daemon (Executer, NameServer, configuration replica) of host b\n")
  T.ok(not unit:find("DCA_DAEMON_ARGS", 1, true), unit)
  T.eq(files["hosts"], "# written by `dca deploy s.dca --hosts h`\na 10.0.0.1:7000\nb 10.0.0.2:7000\nc 10.0.0.3:7001\n")
end)

suite:case("the_package_unit_takes_its_options_from_etc_default", function()
  local unit = deploy.unit()
  T.contains(unit, "EnvironmentFile=-/etc/default/dca-daemon\n")
  T.contains(unit, "\nExecStart=/usr/bin/dca daemon --key /etc/dca/key --state-dir %S/dca $DCA_DAEMON_ARGS\n")
  T.contains(unit, "\nType=notify\n")
  T.ok(unit:match("^%[Unit%]\n"), unit)
end)

return suite:run(...)
