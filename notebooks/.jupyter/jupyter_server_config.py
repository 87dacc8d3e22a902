# The students' JupyterLab (`make lab`): the Makefile puts this folder (notebooks/.jupyter) first on JUPYTER_CONFIG_PATH,
# so it applies to this project only (never to the user's ~/.jupyter). Students see nbgrader's student
# side alone: the instructor's server extensions (formgrader, course list) are off here and their lab
# plugins in labconfig/page_config.json; nbgrader's Validate is replaced by labkit_validate (this
# folder), which validates exercises and says that a lesson notebook is not one.
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

c = get_config()  # noqa: F821 -- provided by the config loader
c.ServerApp.jpserver_extensions = {
    "nbgrader.server_extensions.formgrader": False,
    "nbgrader.server_extensions.course_list": False,
    "nbgrader.server_extensions.validate_assignment": False,
    "labkit_validate": True,
}
