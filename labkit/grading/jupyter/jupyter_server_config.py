# The students' JupyterLab (`labkit lab`, `make lab`): `labkit lab` puts this folder first on JUPYTER_CONFIG_PATH
# for the server it starts, so it applies there only (never to the user's ~/.jupyter nor to another `jupyter lab`).
# Students see nbgrader's student side alone: the instructor's server extensions (formgrader, course list) are off
# here and their lab plugins in labconfig/page_config.json; nbgrader's Validate is replaced by
# labkit.grading.lab_validate, which runs `labkit grade --check` on the notebook (the student's code in the grading
# sandbox, the checks in a process of their own) and says that a lesson notebook is not an exercise.
c = get_config()  # type: ignore[name-defined]  # noqa: F821 -- provided by the config loader
c.ServerApp.jpserver_extensions = {
    "nbgrader.server_extensions.formgrader": False,
    "nbgrader.server_extensions.course_list": False,
    "nbgrader.server_extensions.validate_assignment": False,
    "labkit.grading.lab_validate": True,
}
