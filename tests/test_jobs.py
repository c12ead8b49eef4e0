"""The lines long jobs print, and what a script prints on Ctrl-C or a JobError."""

from temp_gym.jobs import JobError, estimate_line, format_duration, progress_line, run_script


def test_progress_and_estimate_lines():
    assert progress_line(0, 133, "units") == "starting: 133 units"
    assert progress_line(80, 133, "units") == "resuming: 80/133 units done"
    assert progress_line(133, 133, "units") == "all 133 units done"
    line = estimate_line(53, 9.1, 2, "units", "measured on 20 stored units")
    assert line == (
        "estimate: ~4 min for 53 units on 2 workers (9.1 s per unit, measured on 20 stored units)"
    )
    assert estimate_line(3, 60.0, None, "epochs", "measured").startswith(
        "estimate: ~3 min for 3 epochs (60 s per epoch"
    )
    assert [format_duration(s) for s in (45, 600, 9000)] == ["45 s", "10 min", "2.5 h"]


def test_run_script_turns_ctrl_c_and_job_errors_into_one_line(capsys):
    def interrupted(argv):
        raise KeyboardInterrupt

    def refused(argv):
        raise JobError("data/x.npy: damaged; rerun generate.py")

    assert run_script("job.py", interrupted) == 130
    assert capsys.readouterr().err == "job.py: interrupted; rerun the same command to resume\n"
    assert run_script("job.py", refused) == 2
    assert capsys.readouterr().err == "job.py: error: data/x.npy: damaged; rerun generate.py\n"
    assert run_script("job.py", lambda argv: None) == 0


def test_sigterm_ends_a_job_in_one_line_as_ctrl_c_does(tmp_path):
    # kill, Slurm, systemd and docker stop send SIGTERM: it left worker tracebacks, no hint.
    import signal
    import subprocess
    import sys
    import textwrap

    script = textwrap.dedent(
        """
        import sys, time
        from temp_gym.jobs import run_script

        def main(argv):
            print("ready", flush=True)
            time.sleep(60)

        sys.exit(run_script("job.py", main))
        """
    )
    job = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True)  # fmt: skip
    assert job.stdout.readline().strip() == "ready"
    job.send_signal(signal.SIGTERM)
    _, stderr = job.communicate(timeout=60)
    assert job.returncode == 143
    assert stderr == "job.py: terminated; rerun the same command to resume\n"


def test_a_closed_output_ends_a_job_in_one_line(tmp_path):
    # ``bc.py | head`` ended in a BrokenPipeError traceback, and another at exit.
    import subprocess
    import sys
    import textwrap

    script = textwrap.dedent(
        """
        import sys
        from temp_gym.jobs import run_script

        def main(argv):
            for line in range(100_000):
                print("line", line)

        sys.exit(run_script("job.py", main))
        """
    )
    job = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True)  # fmt: skip
    job.stdout.readline()
    job.stdout.close()  # what ``head`` does once it has its lines
    stderr = job.stderr.read()
    assert job.wait(timeout=60) == 141
    assert stderr == "job.py: its output was closed; rerun the same command to resume\n"
