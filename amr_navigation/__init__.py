"""amr_navigation: explore, localize, plan, follow. The one place that decides for a robot (NavigatorCore, around
Navigator's modes), the library loop that carries its calls out in process (NavigationLoop, run_navigation), and the
navigator lifecycle node that carries them out with the controller and planner nodes."""
