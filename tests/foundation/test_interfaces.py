"""amr_interfaces is built into the venv and works over DDS."""

import math

from geometry_msgs.msg import Point
from rclpy.node import Node

from amr_interfaces.msg import SimulatorStatus
from amr_interfaces.srv import ComputeFK, SetPose, SolveIK


def test_solve_ik_round_trip(ros_context, executor):
    server = Node("fake_ik", context=ros_context)
    client_node = Node("ik_client", context=ros_context)

    def answer(request: SolveIK.Request, response: SolveIK.Response) -> SolveIK.Response:
        response.success = request.chain == "arm5"
        response.joint_names = ["q1", "q2"]
        response.positions = [request.target.position.x * 2.0, float(len(request.seed))]
        response.iterations = request.max_iterations + 1
        response.message = f"{request.solver or 'default'} on {request.chain}"
        return response

    server.create_service(SolveIK, "solve_ik", answer)
    client = client_node.create_client(SolveIK, "solve_ik")
    executor.add_node(server)
    executor.add_node(client_node)
    assert client.wait_for_service(timeout_sec=5.0)
    request = SolveIK.Request(chain="arm5", solver="dls", seed=[0.1, 0.2, 0.3], max_iterations=7, timeout=0.5)
    request.target.position.x = 0.053
    future = client.call_async(request)
    executor.spin_until_future_complete(future, timeout_sec=5.0)
    response = future.result()
    assert response.success and response.message == "dls on arm5" and response.iterations == 8
    assert list(response.joint_names) == ["q1", "q2"]
    assert math.isclose(response.positions[0], 0.106) and response.positions[1] == 3.0


def test_other_interfaces_have_their_fields():
    fk = ComputeFK.Response(joint_origins=[Point(x=1.0)], success=True)
    assert fk.joint_origins[0].x == 1.0
    assert SetPose.Request(x=1.0, y=-1.0, theta=1.5).theta == 1.5
    assert SimulatorStatus(collisions=3, goal_reached=True).collisions == 3
